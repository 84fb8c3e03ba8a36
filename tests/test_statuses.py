"""Statuses that do not lie (issue 41, item 6): ``infeasible`` only with a proof, for every method; a method that finds
no point says so (``numerical`` or ``error``, with the reason), never ``infeasible``.

The structure: a 3x3 stack-bond wall whose bottom middle block is left out, so that the middle block above it is held
only by side friction (and carries the top middle block).  The static LP solves it (associative lam 0.15967), but the
non-associative problem (3) has no solution: ``milp``'s lifted relaxation, which holds every solution of (3), is
infeasible at its root, on a checked Farkas certificate (and SCIP proves the independent statement's MPEC infeasible,
tests/references.py).  There the fixed point's dead-load start (and every other
start) meets an infeasible step LP at its second step."""

import numpy as np
import pytest
from references import SIDE_FRICTION_WALL_ASSOCIATIVE, side_friction_wall  # the wall of the module docstring

import blockmpec as bm
from blockmpec.result import Status


def test_the_side_friction_wall_has_an_associative_collapse():
    """The structure is sound for the LPs: both the static and the kinematic LP give lam = 0.15967."""
    wall = side_friction_wall()
    assert wall.n_free == 8
    static, kinematic = bm.solve(wall, "static-lp"), bm.solve(wall, "kinematic-lp")
    assert static.status is Status.OPTIMAL and kinematic.status is Status.OPTIMAL
    # the independent static LP's optimum (references.py): 1.1e-15 and 6.7e-16 measured
    assert static.multiplier == pytest.approx(SIDE_FRICTION_WALL_ASSOCIATIVE, rel=1e-9)
    assert kinematic.multiplier == pytest.approx(SIDE_FRICTION_WALL_ASSOCIATIVE, rel=1e-9)


def test_milp_proves_that_3_has_no_solution():
    """milp's branch and bound finds no point and an infinite bound: a proof (each infeasible node LP pruned on a
    checked Farkas certificate), so the status is infeasible, with the reason (no heuristic start: they find no
    point here, and the fixed point's engines take 10-15 s to say so)."""
    from milp_runs import solve_milp

    res = solve_milp(side_friction_wall(), heuristic="", time_limit=120)
    assert res.status is Status.INFEASIBLE, res.message
    assert res.multiplier is None
    assert "no solution" in res.message and "Farkas" in res.message
    assert res.extra["infeasibility_proofs"] >= 1


@pytest.mark.slow
def test_milp_with_its_default_settings_says_infeasible():
    res = bm.solve(side_friction_wall(), "milp", time_limit=120)
    assert res.status is Status.INFEASIBLE, res.message


def test_a_farkas_certificate_is_checked_not_trusted():
    """proves_infeasible accepts a ray that proves {x >= 1, x <= 0} empty and rejects one that does not (or a
    ray of the wrong sign on a one-sided row, which it drops)."""
    import scipy.sparse as sp

    from blockmpec.solvers.engines.complementarity_bnb import proves_infeasible

    A = sp.csc_array(np.array([[1.0], [1.0]]))  # rows: x >= 1, x <= 0
    rl, ru = np.array([1.0, -np.inf]), np.array([np.inf, 0.0])
    cl, cu = np.array([-np.inf]), np.array([np.inf])
    assert proves_infeasible(A, rl, ru, cl, cu, np.array([1.0, -1.0]))
    assert proves_infeasible(A, rl, ru, cl, cu, np.array([-1.0, 1.0]))  # either sign of the ray
    assert not proves_infeasible(A, rl, ru, cl, cu, np.array([1.0, 0.0]))  # leaves x free: no contradiction
    assert not proves_infeasible(A, np.array([1.0, -np.inf]), np.array([np.inf, 2.0]), cl, cu,
                                 np.array([1.0, -1.0]))  # {1 <= x <= 2} is not empty
    assert not proves_infeasible(A, rl, ru, cl, cu, np.zeros(2))


def test_milp_bound_failures_that_prove_nothing_are_errors():
    """Only the associative LP's failure speaks for (3) (no statically admissible field: infeasible; no collapse:
    unbounded); any other bound LP that fails leaves milp without a bound: error, not unbounded or infeasible."""
    from blockmpec.solvers.engines.mpec_bounds import BoundFailure

    assert BoundFailure(Status.INFEASIBLE, "", proof=True).run_status is Status.INFEASIBLE
    assert BoundFailure(Status.UNBOUNDED, "", proof=True).run_status is Status.UNBOUNDED
    assert BoundFailure(Status.UNBOUNDED, "").run_status is Status.ERROR
    assert BoundFailure(Status.INFEASIBLE, "").run_status is Status.ERROR
    assert BoundFailure(Status.TIME_LIMIT, "").run_status is Status.TIME_LIMIT


@pytest.mark.slow
def test_fixed_point_never_calls_a_failed_step_infeasible():
    """The dead-load start meets an infeasible step LP at step 2; so does every other start.  The run says numerical,
    lists each start's failure, and says that this is no proof."""
    res = bm.solve(side_friction_wall(), "fixed-point", time_limit=60)
    assert res.status is Status.NUMERICAL, res.message
    failed = res.extra["failed_starts"]
    assert failed[0].startswith("dead-load start: iteration 2: the step LP is infeasible")
    assert any(f.startswith("associative start") for f in failed) and any(f.startswith("zero start") for f in failed)
    assert "does not show that (3) has no solution" in res.message


def test_fixed_point_takes_another_start_after_a_failed_step(monkeypatch):
    """A failed step of the dead-load start (simulated on the 2x2 wall: its step LPs are made to fail) is followed
    by the associative start, whose solution is returned, with the failure in the message."""
    from blockmpec.solvers import fixed_point
    from blockmpec.solvers.engines import lp_sequence

    run_sequence = lp_sequence.run_sequence

    def dead_load_fails(seq, *, start, **kwargs):
        out, facts = run_sequence(seq, start=start, **kwargs)
        if start == "dead-load":
            out.status, out.message = Status.NUMERICAL, "iteration 2: the step LP is infeasible (simulated)"
            facts["step_failure"] = "infeasible"
        return out, facts

    monkeypatch.setattr(lp_sequence, "run_sequence", dead_load_fails)
    res = bm.solve(bm.cases.wall(2, 2), "fixed-point")
    assert res.status is Status.CONVERGED and res.verified, res.message
    assert res.extra["start"] == "associative"
    assert res.extra["failed_starts"] == ["dead-load start: iteration 2: the step LP is infeasible (simulated)"]
    assert "simulated" in res.message
    assert fixed_point.FALLBACK_STARTS[0] == "dead-load"


@pytest.mark.slow
@pytest.mark.parametrize("method", ["nlp", "mcp-newton", "slp"])
def test_heuristics_that_find_no_point_do_not_say_infeasible(method):
    """The heuristics on the wall without a solution of (3): none finds a verified point, none says infeasible."""
    res = bm.solve(side_friction_wall(), method, time_limit=60)
    assert not (res.status.is_success and res.verified)
    assert res.status is not Status.INFEASIBLE, res.message

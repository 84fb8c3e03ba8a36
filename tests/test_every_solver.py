"""One generic suite run over every registered method (benchopt/Pyomo style).

Closed form used: a single b x h block on a fixed base has a statically
determinate interface, so every solution of (3), associative or not, has
``lam = min(mu, b/h)``.
"""

import math

import pytest

import blockmpec as bm
from blockmpec.result import Status

METHODS = bm.list_solvers()


@pytest.fixture(params=METHODS, ids=str)
def method(request):
    reason = bm.get_solver(request.param).unavailable_reason()
    if reason:
        pytest.skip(reason)
    return request.param


@pytest.mark.parametrize(("width", "height", "mu"), [(1.0, 2.0, 0.65), (1.0, 1.0, 0.3)])
def test_single_block_closed_form(method, width, height, mu):
    res = bm.solve(bm.cases.single_block(width=width, height=height, mu=mu), method)
    if bm.get_solver(method).exact_solution:
        assert res.success, f"{method}: {res.status} {res.message} {res.residuals}"
    else:  # a heuristic: the right lam, and a status that says whether (3) holds
        assert res.status in (Status.CONVERGED, Status.NUMERICAL), (res.status, res.message)
        assert res.success == (res.max_residual <= res.verify_tol)
    assert res.multiplier == pytest.approx(min(mu, width / height), rel=1e-6)


def test_result_is_complete_and_timed(method):
    res = bm.solve(bm.cases.two_blocks(eta=2, mu=0.65), method)
    assert isinstance(res.status, Status)
    assert res.method == method
    assert res.build_time_s >= 0 and res.solve_time_s > 0
    assert res.iterations >= 0
    d = res.to_dict()
    for key in ("method", "status", "success", "multiplier", "residuals", "time_s", "iterations"):
        assert key in d
    if res.status.is_success:
        assert set(res.residuals) >= {"equilibrium", "friction_admissibility", "compatibility"}
        assert all(math.isfinite(v) for v in res.residuals.values())
    # the REPL's view: one line with what was solved and how well, no array dumped
    shown = repr(res)
    assert "\n" not in shown and len(shown) < 600
    assert f"method={method!r}" in shown and f"status={res.status.value!r}" in shown
    assert f"verified={res.verified}" in shown
    if res.multiplier is not None:
        assert f"{res.multiplier:.10g}" in shown
    assert "array(" not in repr(res.solution)


def test_claimed_success_is_downgraded_when_verifier_disagrees(method):
    case = bm.cases.two_blocks(eta=2, mu=0.65)
    # verify_tol = inf never downgrades: the status is the method's own claim
    claim = bm.solve(case, method, verify_tol=math.inf)
    assert claim.status.is_success and claim.verified, (claim.status, claim.message)
    # no residual is <= -1: the verification is impossible, so the claimed success must become NUMERICAL
    strict = bm.solve(case, method, verify_tol=-1.0)
    assert strict.status is Status.NUMERICAL, (strict.status, strict.message)
    assert not strict.verified and not strict.success
    assert "verifier disagrees" in strict.message and claim.status.value in strict.message
    assert strict.multiplier == pytest.approx(claim.multiplier, rel=1e-9)  # same answer, only the verdict differs


def test_failure_is_not_relabelled_by_the_verifier(method):
    # the centroid overhangs the only support and mu = 0.5 cannot hold it: no method has an answer
    polys = [[[0, -1], [1, -1], [1, 0], [0, 0]], [[0.5, 0], [2.5, 0], [2.5, 1], [0.5, 1]]]
    case = bm.make_structure(polys, [True, False], friction=0.5)
    claim = bm.solve(case, method, verify_tol=math.inf)
    strict = bm.solve(case, method, verify_tol=-1.0)
    assert not claim.status.is_success, (claim.status, claim.message)
    assert strict.status is claim.status and not strict.success


def test_options_are_validated(method):
    with pytest.raises(bm.OptionError, match=rf"method '{method}' has no option 'no_such_option'"):
        bm.solve(bm.cases.single_block(), method, no_such_option=1)


def test_skip_is_a_status_not_an_exception(method, monkeypatch):
    cls = bm.get_solver(method)
    monkeypatch.setattr(cls, "requires", ("a_module_that_does_not_exist",))
    res = bm.solve(bm.cases.single_block(), method)
    assert res.status is Status.SKIPPED and "a_module_that_does_not_exist" in res.message


#: the methods that record a trace (the iterative ones); the others' traces are empty
TRACED = {"fixed-point", "slp", "mcp-newton", "nlp", "milp"}
#: per-record keys the comparator's figures read: the convergence plot reads ``multiplier`` of the
#: iterative heuristics, the error plot reads ``bound`` and ``incumbent`` of milp's certificate
TRACE_KEYS = {"milp": {"bound", "incumbent"}}


def test_every_method_is_classified_as_traced_or_not():
    assert TRACED <= set(METHODS), TRACED - set(METHODS)


def test_trace_times_are_elapsed_and_increasing(method):
    res = bm.solve(bm.cases.wall(courses=3, blocks_per_course=2), method)
    if method not in TRACED:
        assert res.trace == [], f"{method} now writes a trace: add it to TRACED"
        return
    assert res.trace, f"{method} wrote no trace ({res.status.value}: {res.message})"
    keys = {"iteration", "time_s"} | TRACE_KEYS.get(method, {"multiplier"})
    for rec in res.trace:
        assert keys <= set(rec), (method, keys - set(rec))
    times = [rec["time_s"] for rec in res.trace]
    assert all(b >= a for a, b in zip(times, times[1:])), times
    assert times[-1] <= res.solve_time_s + 1e-6
    iterations = [rec["iteration"] for rec in res.trace]
    assert all(b >= a for a, b in zip(iterations, iterations[1:])), iterations

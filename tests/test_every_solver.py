"""Every registered method passes the shipped conformance suite, :func:`blockmpec.testing.check_solver`.

One suite for ours and for plug-ins: what this file runs on the built-in methods is what a researcher runs on their
own (``docs/guide/your-own-method.md``).  The checks, their references (closed forms of the paper's Sect. 3, the
round arch of its Table 1, the static LP, ``milp``'s certificates), each with its source, and their tolerances (at
the accuracy a verified point guarantees, with the errors the built-in methods reach) are documented in
``blockmpec/testing/conformance.py`` and ``blockmpec/testing/references.py``; the suite's own failure modes (a
multiplier 1 % off, a false ``infeasible``, an ignored time limit, an unchecked option) are tested in
``tests/test_plugins.py``.  Here also: what run_solver does alike for every method (the verifier's verdict, a
missing backend), and the traces the comparator's figures read.
"""

import math

import pytest

import blockmpec as bm
from blockmpec.result import Status
from blockmpec.testing import CHECKS, check_solver

METHODS = bm.list_solvers()


@pytest.mark.parametrize("method", METHODS)
def test_method_passes_the_conformance_suite(method):
    table = check_solver(method)  # raises an AssertionError naming every failed check
    ran = table[~table["skipped"]]
    assert set(ran["check"]) == set(CHECKS), set(CHECKS) - set(ran["check"])  # every check ran, none only skipped
    assert ran["passed"].all()


@pytest.mark.parametrize("method", ["static-lp", "fixed-point"])
def test_the_verifiers_verdict_is_final(method):
    case = bm.cases.two_blocks(eta=2, mu=0.65)
    # verify_tol = inf never downgrades: the status is the method's own claim
    claim = bm.solve(case, method, verify_tol=math.inf)
    assert claim.status.is_success and claim.verified, (claim.status, claim.message)
    # no residual is <= -1: the verification is impossible, so the claimed success must become NUMERICAL
    strict = bm.solve(case, method, verify_tol=-1.0)
    assert strict.status is Status.NUMERICAL, (strict.status, strict.message)
    assert not strict.verified and not strict.success
    assert "verifier disagrees" in strict.message and claim.status.value in strict.message
    assert strict.multiplier == claim.multiplier  # the same run, only the verdict differs


def test_a_missing_backend_is_a_skipped_status_not_an_exception(monkeypatch):
    cls = bm.get_solver("static-lp")
    monkeypatch.setattr(cls, "requires", ("a_module_that_does_not_exist",))
    res = bm.solve(bm.cases.single_block(), "static-lp")
    assert res.status is Status.SKIPPED and "a_module_that_does_not_exist" in res.message


#: the built-in methods that record a trace (the iterative ones); the others' traces are empty
TRACED = {"fixed-point", "slp", "mcp-newton", "nlp", "milp"}
#: per-record keys the comparator's figures read: the convergence plot reads ``multiplier`` of the
#: iterative heuristics, the error plot reads ``bound`` and ``incumbent`` of milp's certificate
TRACE_KEYS = {"milp": {"bound", "incumbent"}}


@pytest.mark.parametrize("method", sorted(TRACED | {"static-lp", "kinematic-lp"}))
def test_traces_hold_what_the_comparators_figures_read(method):
    assert TRACED <= set(METHODS), TRACED - set(METHODS)
    res = bm.solve(bm.cases.wall(courses=3, blocks_per_course=2), method)
    if method not in TRACED:
        assert res.trace == [], f"{method} now writes a trace: add it to TRACED"
        return
    assert res.trace, f"{method} wrote no trace ({res.status.value}: {res.message})"
    keys = {"iteration", "time_s"} | TRACE_KEYS.get(method, {"multiplier"})
    for rec in res.trace:
        assert keys <= set(rec), (method, keys - set(rec))

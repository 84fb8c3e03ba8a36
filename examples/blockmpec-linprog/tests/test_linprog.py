"""The plug-in's own tests: blockmpec's conformance suite, cross-checks with blockmpec's methods, and the references
of the built-in cases (``blockmpec_case``, a fixture of blockmpec's pytest plugin).  Run them after
``pip install ./examples/blockmpec-linprog`` with ``python -m pytest`` in this folder."""

import pytest

import blockmpec as bm
from blockmpec.testing import assert_methods_agree, check_solver


@pytest.mark.parametrize("method", ["linprog", "linprog-fixed-point"])
def test_passes_blockmpecs_conformance_suite(method):
    check_solver(method)  # raises an AssertionError naming every failed check


def test_the_lp_agrees_with_blockmpecs_static_lp(blockmpec_case):
    # the associative multiplier is unique; both LPs are verified, so they agree to the verifier's 1e-6
    assert_methods_agree(blockmpec_case.structure, ["linprog", "static-lp"], rtol=1e-6)


def test_the_fixed_point_lies_between_the_minimum_and_the_associative_multiplier(blockmpec_case):
    res = bm.solve(blockmpec_case.structure, "linprog-fixed-point")
    lower, upper = blockmpec_case.bounds("non-associative")  # closed forms, milp's certificates, the static LP
    tol = 1e-6 * max(1.0, upper.value)  # a verified point's multiplier is exact to about verify_tol = 1e-6
    assert res.success, res.message
    assert lower.value - tol <= res.multiplier <= upper.value + tol, (lower, upper)

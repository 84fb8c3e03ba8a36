"""Cross-checks between independent methods on the built-in cases.

* Every verified non-associative result is at least the certified MILP minimum
  (minus 1e-7) wherever the MILP certified its value, and on every case at least
  one heuristic returns a verified solution (so the check is never vacuous).
* Every non-associative result is at most the associative multiplier.
* The MCP's non-uniqueness: at eta = 3, mu = 1.5 the certified minimum is 1/3
  while the associative solution (lam = 2/3) also solves (3), and heuristics
  started from it may stop there.
"""

import pytest

import blockmpec as bm
from blockmpec.result import Status
from helpers import HEURISTICS

CASES = {
    "two-blocks-3-0.65": bm.cases.two_blocks(eta=3, mu=0.65),
    "two-blocks-2-0.3": bm.cases.two_blocks(eta=2, mu=0.3),
    "single-block": bm.cases.single_block(),
    "round-arch": bm.cases.round_arch(),
    "arch-on-buttresses": bm.cases.arch_on_buttresses(),
    "wall-2x2": bm.cases.wall(courses=2, blocks_per_course=2),
    "wall-3x2": bm.cases.wall(courses=3, blocks_per_course=2),
}


@pytest.fixture(scope="module")
def certified():
    out = {}
    for name, s in CASES.items():
        res = bm.solve(s, "milp", time_limit=60.0)
        out[name] = (res, bm.solve(s, "static-lp").multiplier)
    return out


@pytest.mark.parametrize("case", list(CASES))
def test_milp_certifies_the_small_built_in_cases(certified, case):
    res, assoc = certified[case]
    assert res.status is Status.OPTIMAL and res.success, (res.status, res.message)
    assert res.multiplier <= assoc + 1e-9


@pytest.fixture(scope="module")
def heuristic_results():
    """``(case, method) -> Result`` of every heuristic, solved once."""
    cache = {}

    def get(case, method):
        if (case, method) not in cache:
            cache[case, method] = bm.solve(CASES[case], method, time_limit=60.0)
        return cache[case, method]

    return get


@pytest.mark.parametrize("method", HEURISTICS)
@pytest.mark.parametrize("case", list(CASES))
def test_no_verified_result_beats_the_certified_minimum(certified, heuristic_results, case, method):
    ref, assoc = certified[case]
    res = heuristic_results(case, method)
    if res.success:
        assert res.multiplier >= ref.multiplier - 1e-7, (res.multiplier, ref.multiplier)
        assert res.multiplier <= assoc + 1e-9


@pytest.mark.parametrize("case", list(CASES))
def test_some_heuristic_finds_a_verified_solution(heuristic_results, case):
    # the bound check above is vacuous for a failed run: at least one heuristic must succeed on each case
    results = {m: heuristic_results(case, m) for m in HEURISTICS}
    verified = [m for m, r in results.items() if r.success]
    assert verified, {m: (r.status.value, r.message) for m, r in results.items()}


def test_non_uniqueness_at_eta3_mu1p5():
    s = bm.cases.two_blocks(eta=3, mu=1.5)
    assoc = bm.solve(s, "static-lp")
    minimum = bm.solve(s, "milp")
    fixed = bm.solve(s, "fixed-point", start="associative", tie_break="closest")
    assert assoc.multiplier == pytest.approx(2 / 3, rel=1e-9)
    assert minimum.status is Status.OPTIMAL and minimum.multiplier == pytest.approx(1 / 3, abs=1e-7)
    # the fixed point, started from the associative solution, returns a verified solution of (3) ...
    assert fixed.success
    # ... which lies between the certified minimum and the associative value (here: at the top)
    assert 1 / 3 - 1e-7 <= fixed.multiplier <= 2 / 3 + 1e-9
    assert fixed.multiplier == pytest.approx(2 / 3, rel=1e-7)

"""Cross-checks between independent methods on the built-in cases.

* Every heuristic that aims at a solution of (3) (fixed-point, mcp-newton, nlp) returns a verified one on every
  case, at least the certified MILP minimum and at most the associative multiplier; slp does too, or reports its
  point unverified (``helpers.assert_reported_unverified``).
* The MCP's non-uniqueness: at eta = 3, mu = 1.5 the certified minimum is 1/3
  while the associative solution (lam = 2/3) also solves (3), and heuristics
  started from it may stop there.
"""

import pytest
from references import ARCH_ON_BUTTRESSES_ASSOCIATIVE, ROUND_ARCH_ASSOCIATIVE, WALL_2X2_MINIMUM, WALL_3X2_MINIMUM

import blockmpec as bm
from blockmpec.result import Status
from helpers import HEURISTICS, SOLVES_SMALL_CASES, assert_reported_unverified, margin

CASES = {
    "two-blocks-3-0.65": bm.cases.two_blocks(eta=3, mu=0.65),
    "two-blocks-2-0.3": bm.cases.two_blocks(eta=2, mu=0.3),
    "single-block": bm.cases.single_block(),
    "round-arch": bm.cases.round_arch(),
    "arch-on-buttresses": bm.cases.arch_on_buttresses(),
    "wall-2x2": bm.cases.wall(courses=2, blocks_per_course=2),
    "wall-3x2": bm.cases.wall(courses=3, blocks_per_course=2),
}

#: the least multiplier of (3) per case: closed forms (paper Sect. 3: 1/eta for eta = 3, mu = 0.65; mu for eta = 2,
#: mu = 0.3; the single block's b/h = 1/2) and SCIP's certified minima of the independent statement (references.py)
MINIMA = {"two-blocks-3-0.65": 1 / 3, "two-blocks-2-0.3": 0.3, "single-block": 0.5,
          "round-arch": ROUND_ARCH_ASSOCIATIVE, "arch-on-buttresses": ARCH_ON_BUTTRESSES_ASSOCIATIVE,
          "wall-2x2": WALL_2X2_MINIMUM, "wall-3x2": WALL_3X2_MINIMUM}


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
    assert res.multiplier == pytest.approx(MINIMA[case], rel=1e-9)  # 1.1e-12 at most measured (the round arch)
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
def test_every_heuristic_lies_between_the_certified_minimum_and_the_associative_multiplier(
        certified, heuristic_results, case, method):
    """Within 1e-9 (lam's scale max(1, |lam|)): measured, the fixed point's tie-break lowers lam by 1e-10 on the 3x2
    wall by design, nlp exceeds the associative lam by 3.9e-15.  slp's LPs are not (3): on 4 of these 7 cases its
    point is unverified, and says so."""
    ref, assoc = certified[case]
    res = heuristic_results(case, method)
    if method not in SOLVES_SMALL_CASES and not res.success:
        assert_reported_unverified(res)
        return
    assert res.success, (res.status, res.message)
    assert res.multiplier >= ref.multiplier - margin(1e-9, ref.multiplier)
    assert res.multiplier <= assoc + margin(1e-9, assoc)


def test_non_uniqueness_at_eta3_mu1p5():
    s = bm.cases.two_blocks(eta=3, mu=1.5)
    assoc = bm.solve(s, "static-lp")
    minimum = bm.solve(s, "milp")
    fixed = bm.solve(s, "fixed-point", start="associative", tie_break="closest")
    # closed forms (paper Sect. 3: A3, lam = 2/eta; NA2, lam = 1/eta), reached exactly (error 0 measured): round-off
    assert assoc.multiplier == pytest.approx(2 / 3, rel=1e-12)
    assert minimum.status is Status.OPTIMAL and minimum.multiplier == pytest.approx(1 / 3, rel=1e-12)
    # the fixed point, started from the associative solution, returns a verified solution of (3) ...
    assert fixed.success
    # ... which lies between the certified minimum and the associative value (here: at the top)
    assert 1 / 3 - 1e-7 <= fixed.multiplier <= 2 / 3 + 1e-9
    # error 0 measured; the fixed point's tie-break may lower lam by 1e-10 by design (solvers/fixed_point.py)
    assert fixed.multiplier == pytest.approx(2 / 3, abs=1e-9)

"""The built-in case ``ferris-tinloi``: Ferris & Tin-Loi's six walls as published in MPECLib (issue 53, item 1)."""

import pytest

import blockmpec as bm

pytest.importorskip("highspy")

#: wall -> (free blocks, interfaces, associative multiplier at mu = 0.65).  Sizes: MPECLib's block and contact sets
#: (fr_block1.dat ... fr_block6.dat: ``set block``, ``set contact``).  Multipliers: the associative LP of MPECLib's
#: own GAMS model (its contact matrix from fr_genct.gms with the bottom course's two moment arms corrected, Coulomb
#: rows at phi = atan 0.65, rocking rows |mw| <= n) rebuilt in numpy and solved by scipy's HiGHS dual simplex at
#: 1e-10 (an independent statement of the same walls; issue 53 quotes them to 7 digits); with MPECLib's arms as
#: published wall 3 gives 0.3738285478488 instead.
WALLS = {
    1: (33, 83, 0.6428590033139121),
    2: (55, 141, 0.5799986113337297),
    3: (46, 102, 0.4036941035441145),
    4: (55, 116, 0.33194839523999115),
    5: (61, 120, 0.23964252515221848),
    6: (146, 345, 0.34782456419883856),
}


@pytest.mark.parametrize("number", list(WALLS))
def test_each_wall_has_mpeclibs_size_and_associative_multiplier(number):
    """The blocks and interfaces of MPECLib's wall, and its associative multiplier to 1e-12 (measured: at most
    7e-14 apart)."""
    free, interfaces, lam = WALLS[number]
    wall = bm.cases.build_case("ferris-tinloi", wall=number)
    assert wall.n_free == free
    assert bm.operators.assemble(wall).n_interfaces == interfaces
    res = bm.solve(wall, "static-lp")
    assert res.status is bm.Status.OPTIMAL
    assert res.multiplier == pytest.approx(lam, abs=1e-12)


def test_the_default_is_wall_1_as_before():
    """``ferris-tinloi`` without ``wall`` is wall 1 (the case before it had walls); Ferris & Tin-Loi publish its
    associative multiplier as about 0.643."""
    default = bm.cases.build_case("ferris-tinloi")
    assert default.metadata["wall"] == 1
    assert bm.operators.assemble(default).n_interfaces == WALLS[1][1]
    assert round(bm.solve(default, "static-lp").multiplier, 3) == 0.643


def test_mu_dilatancy_and_wall_are_parameters():
    wall = bm.cases.build_case("ferris-tinloi", wall=4, mu=0.65, dilatancy=0.65)
    assert bm.solve(wall, "static-lp").multiplier == pytest.approx(WALLS[4][2], abs=1e-12)
    with pytest.raises(bm.errors.OptionError, match="courses"):
        bm.cases.build_case("ferris-tinloi", courses=3)
    for bad in (0, 7, 1.5, "2"):
        with pytest.raises(bm.errors.OptionError, match="wall"):
            bm.cases.build_case("ferris-tinloi", wall=bad)


@pytest.mark.slow
def test_milp_stops_with_its_bound_and_its_best_exact_point():
    """Not certified in a short run (the lifted root LP of wall 1 gives no bound within the time limit): the stop
    returns its best exact point of (3), at most the fixed point's (its heuristics run first; the fixed point's lam
    is that of an exact solution only to its verification tolerance, 1e-6), and a bound below it; the message and
    ``extra`` report both and the gap."""
    wall = bm.cases.build_case("ferris-tinloi")
    res = bm.solve(wall, "milp", time_limit=30)
    fixed_point = bm.solve(wall, "fixed-point")
    assert fixed_point.verified
    assert res.status is bm.Status.TIME_LIMIT, res.message
    assert res.verified and res.multiplier <= fixed_point.multiplier + 1e-6
    assert res.extra["bound"] is not None and res.extra["bound"] <= res.multiplier
    assert res.extra["gap_abs"] == pytest.approx(res.multiplier - res.extra["bound"], abs=1e-12)
    assert "best lam" in res.message and "bound" in res.message and "gap" in res.message

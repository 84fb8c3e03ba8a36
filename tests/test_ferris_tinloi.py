"""The built-in case ``ferris-tinloi``: Ferris & Tin-Loi's wall 1 (issue 41, item 5)."""

import pytest

import blockmpec as bm

pytest.importorskip("highspy")


def test_the_wall_has_the_published_size_and_associative_multiplier():
    """33 free blocks, 83 interfaces (six on the base), and the associative multiplier 0.642859 (published about
    0.643) at mu = 0.65."""
    wall = bm.cases.build_case("ferris-tinloi")
    assert wall.n_free == 33
    assert bm.operators.assemble(wall).n_interfaces == 83
    res = bm.solve(wall, "static-lp")
    assert res.status is bm.Status.OPTIMAL
    assert res.multiplier == pytest.approx(0.642859, abs=5e-7)
    assert round(res.multiplier, 3) == 0.643


def test_mu_and_dilatancy_are_parameters():
    wall = bm.cases.build_case("ferris-tinloi", mu=0.65, dilatancy=0.65)
    assert bm.solve(wall, "static-lp").multiplier == pytest.approx(0.642859, abs=5e-7)
    with pytest.raises(bm.errors.OptionError, match="courses"):
        bm.cases.build_case("ferris-tinloi", courses=3)


@pytest.mark.slow
def test_milp_stops_with_its_bound_and_its_best_point():
    """Not certified in a short run (the root LP alone is beyond 10 minutes: studies/lab/certificate_vs_textbook.py):
    the stop reports a bound below its verified best point, which is at most the fixed point's."""
    wall = bm.cases.build_case("ferris-tinloi")
    res = bm.solve(wall, "milp", time_limit=15)
    assert res.status is bm.Status.TIME_LIMIT, res.message
    assert res.verified and res.multiplier <= 0.63997 + 1e-6
    assert res.extra["bound"] is not None and res.extra["bound"] <= res.multiplier
    assert "bound" in res.message and "best lam" in res.message

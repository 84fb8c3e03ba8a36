"""``studies/root_lp_engines.py`` (issue 12's record of root-LP engines) still runs: its root LP is the one ``milp``
bounds with (IPX's dual bound on it meets the certified minimum of the 2x2 running-bond wall, never above it), a
lifting without the products with the mechanism gives a weaker bound, and its profile parses IPX's log."""

from pathlib import Path

import pytest

import blockmpec as bm
from helpers import CERTIFIED_TOL, load_study, margin


@pytest.fixture(scope="module")
def study():
    return load_study("root_lp_engines")


@pytest.fixture(scope="module")
def minimum():
    res = bm.solve(bm.cases.wall(2, 2, mu=0.65), "milp", engine="highs")
    assert res.status is bm.Status.OPTIMAL, res.message
    return res.multiplier


def test_ipx_bound_on_the_study_root_lp_is_the_certified_minimum(study, minimum):
    (row,) = study.engines(["2x2"], ["ipx"], time_limit=60)
    assert row["bound"] <= minimum + margin(CERTIFIED_TOL, minimum)
    assert minimum - row["bound"] <= margin(CERTIFIED_TOL, minimum)


def test_liftings_without_the_force_products_give_a_weaker_bound(study, minimum):
    bounds = {row["lifting"]: row["bound"] for row in study.liftings(["2x2"], time_limit=60)}
    assert max(bounds.values()) <= minimum + margin(CERTIFIED_TOL, minimum)
    assert minimum - bounds["rlt-full"] <= margin(CERTIFIED_TOL, minimum)
    assert bounds["friction"] < minimum - 0.1


def test_profile_reads_ipx_log(study, tmp_path, monkeypatch):
    monkeypatch.setattr(study, "OUT", tmp_path)
    (row,) = study.profile(["2x2"], "rlt", time_limit=60)
    assert row["status"] == "Optimal"
    assert row["iterations"] > 0 and row["last_gap"] < 1e-6
    assert Path(row["log"]).parent == tmp_path


def test_the_null_space_root_lp_gives_the_lifted_bound(study, minimum):
    """The study's ``ipx-null-space`` engine (the root LP ``root_lp="ipm"`` now solves) is the same LP in other
    coordinates: its bound equals IPX's on the lifted LP and meets the certified minimum, on fewer rows."""
    lifted, reduced = study.engines(["2x2"], ["ipx", "ipx-null-space"], time_limit=60)
    assert reduced["rows"] < lifted["rows"]
    assert reduced["bound"] <= minimum + margin(CERTIFIED_TOL, minimum)
    assert abs(reduced["bound"] - lifted["bound"]) <= margin(CERTIFIED_TOL, minimum)

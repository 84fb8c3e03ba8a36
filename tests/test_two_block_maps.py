"""The two-block maps study reproduces the paper's closed-form mechanism regions (Sect. 3, Figs 5-6).

Panels (a) associative (static-lp), (b) certified non-associative minimum (milp)
and (c) certified non-associative maximum (milp, sense="max").  For (c) the paper
states that the maximum equals the associative multiplier, with the non-dilatant
counterpart of the associative mechanism (A1 -> NA1, A2-1 / A2-2 -> NA2, A3 -> NA3).
"""

from __future__ import annotations

import numpy as np
import pytest

import blockmpec as bm
from helpers import load_study


@pytest.fixture(scope="module")
def study():
    return load_study("two_block_maps")


@pytest.fixture(scope="module")
def table(study):
    if "milp" not in bm.list_solvers():
        pytest.skip("milp method not registered")
    # a 6 x 6 grid that crosses every boundary, plus the paper's example point (3, 0.65)
    etas = list(np.linspace(1.1, 5.6, 6)) + [3.0]
    mus = list(np.linspace(0.15, 1.4, 6)) + [0.65]
    t, _ = study.sample(etas, mus)
    return t


def test_non_associative_minimum_slides_iff_mu_below_one_over_eta(table):
    certified = table["na_min_status"] == "optimal"
    assert certified.mean() > 0.9, table.loc[~certified, ["eta", "mu", "na_min_status"]]
    t = table[certified & (np.abs(table["mu"] - 1 / table["eta"]) > 1e-6)]
    sliding = t["na_min_mechanism"] == "NA1"
    np.testing.assert_array_equal(sliding.values, (t["mu"] < 1 / t["eta"]).values)
    assert set(t.loc[~sliding, "na_min_mechanism"]) == {"NA2"}
    np.testing.assert_allclose(t["na_min_lam"], np.minimum(t["mu"], 1 / t["eta"]), rtol=1e-7)


def test_associative_regions_follow_the_closed_forms(study, table):
    checked = 0
    for _, r in table.iterrows():
        if np.isnan(r["closed_form_associative"]):
            continue
        assert r["associative_lam"] == pytest.approx(r["closed_form_associative"], rel=1e-7)
        values = sorted(study.closed_form_candidates(r["eta"], r["mu"]).values())
        if len(values) > 1 and values[1] > values[0] * 1.01:  # away from region boundaries
            assert r["associative_mechanism"] == r["closed_form_mechanism"], (r["eta"], r["mu"])
            checked += 1
    assert checked > 25
    # every associative mechanism of the paper shows up on this grid
    assert {"A1", "A2-1", "A2-2", "A3"} <= set(table["associative_mechanism"])


def test_paper_example_point(table):
    r = table[(table["eta"] == 3.0) & (table["mu"] == 0.65)].iloc[0]
    assert r["associative_lam"] == pytest.approx(0.41973, abs=5e-6)  # paper Sect. 3: A2-1
    assert r["associative_mechanism"] == "A2-1"
    assert r["na_min_lam"] == pytest.approx(1 / 3, rel=1e-8) and r["na_min_mechanism"] == "NA2"


def test_non_associative_maximum_is_the_associative_closed_form(table):
    """Paper Fig. 6c = Fig. 6a: the certified maximum equals the associative closed form."""
    assert (table["na_max_status"] == "optimal").all(), table.loc[table["na_max_status"] != "optimal",
                                                                  ["eta", "mu", "na_max_status"]]
    known = ~np.isnan(table["closed_form_associative"])
    assert known.sum() > 25
    np.testing.assert_allclose(table.loc[known, "na_max_lam"], table.loc[known, "closed_form_associative"],
                               rtol=1e-7)
    np.testing.assert_allclose(table["na_max_lam"], table["associative_lam"], rtol=1e-7)
    # and it is never below the certified minimum
    assert (table["na_max_lam"] >= table["na_min_lam"] - 1e-9).all()


def test_non_associative_maximum_mechanisms_are_the_non_dilatant_counterparts(study, table):
    """Panel (c): NA1 where the associative mechanism is A1, NA2 where A2-1/A2-2, NA3 where A3.

    Checked away from region boundaries: where two associative mechanisms tie (e.g. A3 and
    A2-2 at eta = 2.3, mu = 1.15) the maximiser may be either counterpart.
    """
    expected = {"A1": "NA1", "A2-1": "NA2", "A2-2": "NA2", "A3": "NA3"}
    assert study.A_TO_NA == expected

    def clear(r) -> bool:
        values = sorted(study.closed_form_candidates(r["eta"], r["mu"]).values())
        return not np.isnan(r["closed_form_associative"]) and (len(values) == 1 or values[1] > values[0] * 1.01)

    rows = table[table.apply(clear, axis=1)]
    assert len(rows) > 25
    assert rows["associative_mechanism"].isin(list(expected)).all()
    got = rows["na_max_mechanism"].tolist()
    want = [expected[a] for a in rows["associative_mechanism"]]
    bad = [(r.eta, r.mu, r.associative_mechanism, g) for r, g, w in zip(rows.itertuples(), got, want) if g != w]
    assert not bad, bad
    assert set(got) == {"NA1", "NA2", "NA3"}

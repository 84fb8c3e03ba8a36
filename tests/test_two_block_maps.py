"""The two-block maps study reproduces the paper's closed-form mechanism regions (Sect. 3, Figs 5-6)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import blockmpec as bm

STUDY = Path(__file__).resolve().parents[1] / "studies" / "two_block_maps.py"


@pytest.fixture(scope="module")
def study():
    spec = importlib.util.spec_from_file_location("two_block_maps", STUDY)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


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

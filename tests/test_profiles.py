"""Performance profiles and the summary table: exact numbers on a hand-made table."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from blockmpec.bench.profiles import SHIFT_S, profile_data, rho, solved, summary_table


def _rows():
    base = {"problem": "non-associative", "repetition": 0, "verified": True, "reference_source": "certified",
            "reference": 0.5, "wall_limit_s": 100.0}
    rows = [
        # case p1: A fastest, B 4x slower, C wrong answer (not solved)
        {"case": "p1", "method_label": "A", "multiplier": 0.5, "solve_time_s": 1.0},
        {"case": "p1", "method_label": "B", "multiplier": 0.5, "solve_time_s": 4.0},
        {"case": "p1", "method_label": "C", "multiplier": 0.6, "solve_time_s": 0.5},
        # case p2: B fastest, A 2x, C not verified
        {"case": "p2", "method_label": "A", "multiplier": 0.5, "solve_time_s": 2.0},
        {"case": "p2", "method_label": "B", "multiplier": 0.5, "solve_time_s": 1.0},
        {"case": "p2", "method_label": "C", "multiplier": 0.5, "solve_time_s": 0.1, "verified": False},
    ]
    df = pd.DataFrame([{**base, **r} for r in rows])
    df["rel_error"] = (df["multiplier"] - df["reference"]).abs() / df["reference"]
    return df


def test_solved_needs_verification_and_the_reference():
    df = _rows()
    assert solved(df).tolist() == [True, True, False, True, True, False]
    # below an inexact reference (best value of another method) is a better answer, not a failure
    better = pd.DataFrame([{"problem": "non-associative", "verified": True, "multiplier": 0.45, "reference": 0.5,
                            "reference_source": "best"}])
    assert solved(better).tolist() == [True]
    assert solved(better.assign(reference_source="certified")).tolist() == [False]


def test_dolan_more_ratios_and_rho():
    data = profile_data(_rows())["non-associative"]
    assert data["cases"] == ["p1", "p2"]
    np.testing.assert_allclose(data["ratios"]["A"], [1.0, 2.0])
    np.testing.assert_allclose(data["ratios"]["B"], [4.0, 1.0])
    assert np.isinf(data["ratios"]["C"]).all()
    np.testing.assert_allclose(rho(data["ratios"]["A"], [1.0, 1.9, 2.0, 10.0]), [0.5, 0.5, 1.0, 1.0])
    np.testing.assert_allclose(rho(data["ratios"]["C"], [1e9]), [0.0])


def test_summary_shifted_geometric_mean_charges_unsolved_runs_their_limit():
    table = summary_table(_rows()).set_index("method")
    sgm = {m: math.exp(np.mean(np.log(np.array(t) + SHIFT_S))) - SHIFT_S
           for m, t in {"A": [1.0, 2.0], "B": [4.0, 1.0], "C": [100.0, 100.0]}.items()}
    for m in "ABC":
        assert table.loc[m, "sgm_time_s"] == pytest.approx(sgm[m], rel=1e-12)
    assert table.loc["A", "sgm_time_ratio"] == pytest.approx(1.0)  # A (sqrt 2) beats B (2)
    assert table.loc["B", "sgm_time_ratio"] == pytest.approx(sgm["B"] / sgm["A"], rel=1e-12)
    assert table.loc["C", "success_rate"] == 0.0 and table.loc["A", "success_rate"] == 1.0
    assert table.loc["C", "median_rel_error"] == pytest.approx(0.1, rel=1e-12)

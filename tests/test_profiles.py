"""Performance profiles and the summary table: exact numbers on a hand-made table, one budget per case."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from blockmpec.bench.profiles import (
    SHIFT_S,
    SOLVED_DEFINITION,
    case_budgets,
    profile_data,
    rho,
    solved,
    summary_table,
    summary_text,
)


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
    df["rel_error"] = (df["multiplier"] - df["reference"]) / df["reference"].abs()
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


def test_summary_shifted_geometric_mean_charges_unsolved_runs_the_case_budget():
    table = summary_table(_rows()).set_index("method")
    sgm = {m: math.exp(np.mean(np.log(np.array(t) + SHIFT_S))) - SHIFT_S
           for m, t in {"A": [1.0, 2.0], "B": [4.0, 1.0], "C": [100.0, 100.0]}.items()}
    for m in "ABC":
        assert table.loc[m, "sgm_time_s"] == pytest.approx(sgm[m], rel=1e-12)
    assert table.loc["A", "sgm_time_ratio"] == pytest.approx(1.0)  # A (sqrt 2) beats B (2)
    assert table.loc["B", "sgm_time_ratio"] == pytest.approx(sgm["B"] / sgm["A"], rel=1e-12)
    assert table.loc["C", "success_rate"] == 0.0 and table.loc["A", "success_rate"] == 1.0
    assert table.loc["C", "median_rel_error"] == pytest.approx(0.1, rel=1e-12)
    assert table.loc["C", "charged_runs"] == 2 and table.loc["A", "charged_runs"] == 0


def test_one_budget_per_case_the_same_for_every_method():
    """The issue's example: slp's unsolved runs were charged its own 900 s limit, milp's its 90 s; now every
    unsolved run of a case is charged that case's budget, whatever the method's own limit."""
    df = _rows()
    df["wall_limit_s"] = [90.0, 900.0, 30.0, 90.0, 900.0, 30.0]  # the methods' own limits differ
    df.loc[df["case"] == "p2", "wall_limit_s"] = [90.0, 60.0, 30.0]
    assert case_budgets(df) == {"p1": 900.0, "p2": 90.0}  # the largest wall limit of each case
    table = summary_table(df).set_index("method")
    sgm_c = math.exp(np.mean(np.log(np.array([900.0, 90.0]) + SHIFT_S))) - SHIFT_S
    assert table.loc["C", "sgm_time_s"] == pytest.approx(sgm_c, rel=1e-12)
    # a budget given by the user: for every case, and runs over it are not solved
    table = summary_table(df, budget=3.0).set_index("method")
    assert table.loc["B", "solved"] == 1  # B took 4 s on p1
    sgm_b = math.exp(np.mean(np.log(np.array([3.0, 1.0]) + SHIFT_S))) - SHIFT_S
    assert table.loc["B", "sgm_time_s"] == pytest.approx(sgm_b, rel=1e-12)
    assert np.isinf(profile_data(df, budget=3.0)["non-associative"]["ratios"]["B"][0])
    text = summary_text(summary_table(df, budget={"p1": 5.0}))
    assert "p1 5 s, p2 90 s" in text and "set by the user" in text
    assert "p1 900 s, p2 90 s" in summary_text(summary_table(df))
    # the column written by compare(budget=) is what the summary charges when no budget is passed
    assert summary_table(df.assign(budget_s=2.0)).set_index("method").loc["C", "sgm_time_s"] == pytest.approx(2.0)


def test_the_printed_definition_of_solved_is_the_code_s():
    """The summary prints SOLVED_DEFINITION; each clause of it decides a row here."""
    text = summary_text(summary_table(_rows()))
    assert SOLVED_DEFINITION in text
    for clause in ("verified", "solve time <= the case's budget", "|rel_error| <= 1e-06 against an exact reference",
                   "rel_error <= 1e-06 against the best verified value of another method", "no reference: verified"):
        assert clause in SOLVED_DEFINITION
    base = {"case": "p", "problem": "non-associative", "verified": True, "reference": 0.5, "solve_time_s": 1.0,
            "wall_limit_s": 10.0}
    rows = pd.DataFrame([
        {**base, "multiplier": 0.5 * (1 + 0.9e-6), "reference_source": "certified"},  # within tol of exact
        {**base, "multiplier": 0.5 * (1 - 2e-6), "reference_source": "certified"},  # below exact by > tol
        {**base, "multiplier": 0.4, "reference_source": "best"},  # a new best: solved
        {**base, "multiplier": 0.5 * (1 + 2e-6), "reference_source": "best"},  # above by > tol
        {**base, "multiplier": 0.7, "reference": None, "reference_source": "none"},  # no reference
        {**base, "multiplier": 0.5, "verified": False, "reference_source": "certified"},  # not verified
        {**base, "multiplier": 0.5, "solve_time_s": 11.0, "reference_source": "certified"},  # over the budget
    ])
    assert solved(rows).tolist() == [True, False, True, False, True, False, False]

"""The comparator: reference selection, errors, failures, skips, output files."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

import blockmpec as bm
from blockmpec import registry
from blockmpec.compare import add_references, compare, normalise_methods, parametrised_label, write_tables
from blockmpec.result import Solution, Status
from blockmpec.solver import RunOutput, SolverBase

TWO_BLOCKS = {"two-blocks": ("two-blocks", {"eta": 3.0, "mu": 0.65})}
NA_MIN = 1.0 / 3.0  # closed form, paper Sect. 3: mu > 1/eta -> lam_min = 1/eta
ASSOC = 0.41973  # paper Sect. 3, eta = 3, mu = 0.65 (5 digits)


def _frame(rows):
    base = {"case": "c", "problem": "non-associative", "multiplier": None, "verified": False,
            "certified": False, "closed_form": None}
    return pd.DataFrame([{**base, **r} for r in rows])


# --------------------------------------------------------------------------- reference selection (synthetic)


def test_certified_minimum_is_the_reference_and_undercutting_it_is_an_anomaly():
    df = add_references(_frame([
        {"multiplier": 0.30, "verified": True, "certified": True, "closed_form": 0.25},
        {"multiplier": 0.40, "verified": True},
        {"multiplier": 0.29, "verified": True},  # below the certificate
        {"multiplier": 0.30 - 1e-9, "verified": True},  # within tolerance
        {"multiplier": 0.10, "verified": False},  # not a solution: no anomaly
    ]))
    assert set(df["reference_source"]) == {"certified"}
    assert np.allclose(df["reference"], 0.30)
    assert list(df["anomaly"]) == ["", "", "below-certified-minimum", "", ""]
    expected = np.abs(np.array([0.30, 0.40, 0.29, 0.30 - 1e-9, 0.10]) - 0.30)
    np.testing.assert_allclose(df["abs_error"], expected, rtol=1e-15)
    np.testing.assert_allclose(df["rel_error"], expected / 0.30, rtol=1e-15)


def test_best_verified_value_without_certificate():
    df = add_references(_frame([
        {"multiplier": 0.35, "verified": True, "closed_form": 0.2},
        {"multiplier": 0.31, "verified": True},
        {"multiplier": 0.05, "verified": False},  # unverified values never set the reference
        {"multiplier": None},
    ]))
    assert set(df["reference_source"]) == {"best"}
    assert np.allclose(df["reference"], 0.31)
    assert math.isnan(df["rel_error"].iloc[3])
    assert df["rel_error"].iloc[0] == pytest.approx(0.04 / 0.31, rel=1e-12)


def test_closed_form_then_none():
    df = add_references(_frame([{"multiplier": 0.5, "verified": False, "closed_form": 0.4}]))
    assert df["reference_source"].iloc[0] == "closed-form"
    assert df["rel_error"].iloc[0] == pytest.approx(0.25, rel=1e-12)
    df = add_references(_frame([{"multiplier": 0.5, "verified": False}]))
    assert df["reference_source"].iloc[0] == "none" and math.isnan(df["reference"].iloc[0])
    assert math.isnan(df["rel_error"].iloc[0])


def test_references_are_per_case_and_problem():
    df = add_references(_frame([
        {"case": "a", "problem": "associative", "multiplier": 0.5, "verified": True},
        {"case": "a", "problem": "associative", "multiplier": 0.5 + 1e-3, "verified": True},
        {"case": "a", "problem": "non-associative", "multiplier": 0.45, "verified": True},
        {"case": "a", "problem": "non-associative", "multiplier": 0.6, "verified": True},
        {"case": "b", "problem": "non-associative", "multiplier": 0.7, "verified": True},
    ]))
    assert list(df["reference"]) == [0.5, 0.5, 0.45, 0.45, 0.7]
    # the LP optimum is unique: two verified associative values must agree
    assert df["anomaly"].iloc[1] == "associative-mismatch"
    # no solution of (3) exceeds the associative multiplier
    assert df["anomaly"].iloc[3] == "above-associative"


# --------------------------------------------------------------------------- real runs


def test_two_blocks_certified_minimum_matches_closed_form():
    res: dict = {}
    df = compare(TWO_BLOCKS, ["static-lp", "fixed-point", "milp"], results=res)
    row = df.set_index("method_label")
    assert row.loc["static-lp", "multiplier"] == pytest.approx(ASSOC, abs=5e-6)
    assert row.loc["milp", "status"] == "optimal", row.loc["milp", "message"]
    assert row.loc["milp", "certified"]
    assert row.loc["fixed-point", "reference_source"] == "certified"
    assert row.loc["fixed-point", "reference"] == pytest.approx(NA_MIN, rel=1e-8)
    lam = row.loc["fixed-point", "multiplier"]
    assert row.loc["fixed-point", "rel_error"] == pytest.approx(abs(lam - NA_MIN) / NA_MIN, rel=1e-9)
    assert row.loc["static-lp", "reference_source"] == "best"
    assert set(res) == {("two-blocks", m, 0) for m in ("static-lp", "fixed-point", "milp")}


@pytest.fixture
def dummy_solvers():
    """Three throw-away methods: one raising in run, one raising in setup, one that never fits."""

    class _Base(SolverBase):
        problem = "non-associative"
        summary = "test dummy"

    class RaisesInRun(_Base):
        name = "test-raises-in-run"

        def run(self):
            raise RuntimeError("deliberate failure")

    class RaisesInSetup(_Base):
        name = "test-raises-in-setup"

        def setup(self, ops):
            raise ZeroDivisionError("deliberate set-up failure")

    class NeverFits(_Base):
        name = "test-never-fits"

        def skip_reason(self, ops):
            return "this dummy fits no case"

        def run(self):  # pragma: no cover - never reached
            return RunOutput(Status.CONVERGED, Solution(multiplier=1.0))

    classes = [RaisesInRun, RaisesInSetup, NeverFits]
    registry.list_solvers()  # load the plug-ins first
    for cls in classes:
        registry.register_solver(cls)
    yield [c.name for c in classes]
    for cls in classes:
        registry._SOLVERS.pop(cls.name, None)


def test_failures_and_skips_get_rows_and_the_run_goes_on(dummy_solvers):
    methods = [*dummy_solvers, "static-lp"]
    df = compare(TWO_BLOCKS, methods)
    assert list(df["method"]) == methods
    row = df.set_index("method")
    assert row.loc["test-raises-in-run", "status"] == "error"
    assert "deliberate failure" in row.loc["test-raises-in-run", "message"]
    assert row.loc["test-raises-in-setup", "status"] == "error"
    assert "set-up failed" in row.loc["test-raises-in-setup", "message"]
    assert row.loc["test-never-fits", "status"] == "skipped"
    assert row.loc["test-never-fits", "message"] == "this dummy fits no case"
    for m in dummy_solvers:
        assert not row.loc[m, "success"] and pd.isna(row.loc[m, "multiplier"])
        # nothing verified: the non-associative reference falls back to the closed form
        assert row.loc[m, "reference_source"] == "closed-form"
        assert row.loc[m, "reference"] == pytest.approx(NA_MIN, rel=1e-12)
    assert row.loc["static-lp", "success"]
    assert row.loc["static-lp", "multiplier"] == pytest.approx(ASSOC, abs=5e-6)


def test_exception_escaping_solve_is_caught(monkeypatch):
    from blockmpec import compare as compare_module

    calls = []

    def flaky(ops, method, **kw):
        calls.append(method)
        if len(calls) == 1:
            raise bm.BlockmpecError("escaped from solve")
        return bm.solve(ops, method, **kw)

    monkeypatch.setattr(compare_module, "solve", flaky)
    df = compare({"a": ("single-block", {}), "b": ("single-block", {"mu": 0.3})}, ["static-lp"])
    assert list(df["status"]) == ["error", "optimal"]
    assert "escaped from solve" in df["message"].iloc[0]
    # single block: lam = min(mu, b/h) = min(0.3, 0.5)
    assert df["multiplier"].iloc[1] == pytest.approx(0.3, rel=1e-9)
    assert df["reference_source"].iloc[0] == "closed-form" and df["reference"].iloc[0] == pytest.approx(0.5)


def test_labels_options_repeat_and_columns(tmp_path):
    assert parametrised_label("fixed-point", {"relaxation": 0.5}) == "fixed-point[relaxation=0.5]"
    with pytest.raises(bm.OptionError, match="no option 'nope'"):
        normalise_methods([("fixed-point", {"nope": 1})])
    df = compare({"sb": ("single-block", {"width": 1.0, "height": 4.0})},
                 ["static-lp", ("fixed-point", {"relaxation": 0.5})], repeat=2)
    assert len(df) == 4
    assert list(df["method_label"]) == ["static-lp"] * 2 + ["fixed-point[relaxation=0.5]"] * 2
    assert list(df["repetition"]) == [0, 1, 0, 1]
    assert df["p_case_height"].iloc[0] == 4.0 and df["p_method_relaxation"].iloc[2] == 0.5
    from blockmpec.verify import RESIDUAL_NAMES

    for col in ("case", "case_name", "method", "method_label", "problem", "status", "success", "verified",
                "multiplier", *RESIDUAL_NAMES, "build_time_s", "solve_time_s", "total_time_s", "iterations",
                "message", "reference", "reference_source", "abs_error", "rel_error", "anomaly"):
        assert col in df.columns, col
    np.testing.assert_allclose(df["total_time_s"], df["build_time_s"] + df["solve_time_s"])
    # closed form of the single block: lam = min(mu, b/h) = 0.25 for both problems
    np.testing.assert_allclose(df["multiplier"], 0.25, rtol=1e-8)
    assert (df["rel_error"] < 1e-8).all()
    paths = write_tables(df, tmp_path)
    assert paths[0].name == "results.csv"
    back = pd.read_csv(paths[0])
    assert len(back) == 4 and list(back["method_label"]) == list(df["method_label"])


def test_cli_compare_takes_method_options(tmp_path, capsys):
    from blockmpec.cli import main

    code = main(["compare", "--cases", "two-blocks", "--methods", "static-lp,fixed-point",
                 "-O", "fixed-point.relaxation=0.5", "--out", str(tmp_path), "--no-figures", "--quiet"])
    assert code == 0
    out = capsys.readouterr().out
    assert "0.41973" in out and "Friction admissibility" in out
    df = pd.read_csv(tmp_path / "results.csv")
    assert df.loc[df["method"] == "fixed-point", "p_method_relaxation"].iloc[0] == 0.5
    assert main(["compare", "--methods", "static-lp", "-O", "nlp.tol=1", "--out", str(tmp_path)]) == 2


def test_a_certified_maximum_is_never_the_minimum_reference():
    cases = {"two-blocks": ("two-blocks", {"eta": 3.0, "mu": 0.65})}
    only_max = compare(cases, [("milp", {"sense": "max"})])
    row = only_max.iloc[0]
    assert row["status"] == "optimal" and abs(row["multiplier"] - 0.4197271773) < 1e-7
    assert not row["certified"] and row["reference_source"] != "certified"
    both = compare(cases, [("milp", {"sense": "max"}), "milp"])
    assert set(both["reference_source"]) == {"certified"}
    assert abs(both["reference"].iloc[0] - 1 / 3) < 1e-9

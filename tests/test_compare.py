"""The comparator: honest references and signed errors, failures in isolation, marks, output folders, parallel runs."""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pandas as pd
import pytest
from references import TWO_BLOCKS_ASSOCIATIVE, WALL_4X3_ASSOCIATIVE, WALL_4X3_MINIMUM

import blockmpec as bm
from blockmpec import registry
from blockmpec.bench.compare import (
    add_references,
    cell_mark,
    compare,
    normalise_methods,
    parametrised_label,
    text_table,
)

TWO_BLOCKS = {"two-blocks": ("two-blocks", {"eta": 3.0, "mu": 0.65})}
NA_MIN = 1.0 / 3.0  # closed form, paper Sect. 3: mu > 1/eta -> lam_min = 1/eta
ASSOC = TWO_BLOCKS_ASSOCIATIVE  # closed form, paper Sect. 3, eta = 3, mu = 0.65: A2-1, 1 / 2.3825
#: static-lp's lam through the comparator's worker and its CSV/parquet files against the closed form: 1 ulp measured
EXACT = 1e-12


def _frame(rows):
    base = {"case": "c", "problem": "non-associative", "method": "m", "multiplier": None, "verified": False,
            "certified": False, "closed_form": None}
    df = pd.DataFrame([{**base, **r} for r in rows])
    df["method_label"] = df["method"]
    return df


# --------------------------------------------------------------------------- reference by rank (synthetic)


def test_closed_form_outranks_a_certificate_and_the_best_value():
    df = add_references(_frame([
        {"method": "milp", "multiplier": 0.30, "verified": True, "certified": True, "closed_form": 0.25},
        {"method": "fp", "multiplier": 0.40, "verified": True, "closed_form": 0.25},
    ]))
    assert list(df["reference_source"]) == ["closed-form"] * 2
    assert np.allclose(df["reference"], 0.25) and list(df["reference_method"]) == ["", ""]
    assert list(df["anomaly"]) == ["", ""]
    np.testing.assert_allclose(df["rel_error"], [0.05 / 0.25, 0.15 / 0.25], rtol=1e-14)
    # a verified value below the closed-form minimum is impossible: flagged
    low = add_references(_frame([{"method": "x", "multiplier": 0.2, "verified": True, "closed_form": 0.25}]))
    assert low["anomaly"].iloc[0] == "below-closed-form-minimum"


def test_certificate_of_another_method_then_undercutting_it_is_an_anomaly():
    df = add_references(_frame([
        {"method": "milp", "multiplier": 0.30, "verified": True, "certified": True},
        {"method": "fp", "multiplier": 0.40, "verified": True},
        {"method": "nlp", "multiplier": 0.29, "verified": True},  # below the certificate
        {"method": "slp", "multiplier": 0.10, "verified": False},  # not a solution: no anomaly
    ]))
    assert list(df["reference_source"][1:]) == ["certified"] * 3
    assert list(df["reference_method"][1:]) == ["milp"] * 3
    assert list(df["anomaly"]) == ["", "", "below-certified-minimum", ""]
    np.testing.assert_allclose(df["abs_error"][1:], [0.10, 0.01, 0.20], rtol=1e-12)
    # signed: below a certificate is negative, and not a new best (a certified minimum is exact)
    np.testing.assert_allclose(df["rel_error"][1:], [0.10 / 0.30, -0.01 / 0.30, -0.20 / 0.30], rtol=1e-12)
    np.testing.assert_allclose(df["signed_error"][1:], [0.10, -0.01, -0.20], rtol=1e-12)
    assert list(df["new_best"]) == [False] * 4
    rows = df.assign(case="c", method_label=df["method"], repetition=0, success=df["verified"],
                     status=["optimal", "converged", "converged", "numerical"])
    text = text_table(rows, "multiplier", "{:.2f}", "t", reference=True)
    assert "0.29!" in text and "! = ANOMALY" in text


def test_a_method_is_never_graded_against_its_own_value():
    df = add_references(_frame([
        {"method": "milp", "multiplier": 0.30, "verified": True, "certified": True},
        {"method": "fp", "multiplier": 0.40, "verified": True},
    ]))
    own = df.iloc[0]
    # the only certificate is milp's own: milp is compared with the best value of another method
    assert own["reference_source"] == "best" and own["reference"] == 0.40 and own["reference_method"] == "fp"
    assert "this method's own" in own["reference_note"]
    alone = add_references(_frame([{"method": "fp", "multiplier": 0.4, "verified": True}])).iloc[0]
    assert alone["reference_source"] == "none" and math.isnan(alone["rel_error"])
    assert "no other method produced a verified value" in alone["reference_note"]


def test_best_verified_value_of_another_method():
    df = add_references(_frame([
        {"method": "a", "multiplier": 0.35, "verified": True},
        {"method": "b", "multiplier": 0.31, "verified": True},
        {"method": "c", "multiplier": 0.05, "verified": False},  # unverified values never set the reference
        {"method": "c", "multiplier": None},
    ]))
    assert list(df["reference"]) == [0.31, 0.35, 0.31, 0.31]
    assert list(df["reference_method"]) == ["b", "a", "b", "b"]
    assert math.isnan(df["rel_error"].iloc[3])
    assert df["rel_error"].iloc[0] == pytest.approx(0.04 / 0.31, rel=1e-12)


def test_references_are_per_case_and_problem():
    df = add_references(_frame([
        {"case": "a", "problem": "associative", "method": "s", "multiplier": 0.5, "verified": True},
        {"case": "a", "problem": "associative", "method": "k", "multiplier": 0.5 + 1e-3, "verified": True},
        {"case": "a", "problem": "non-associative", "method": "x", "multiplier": 0.45, "verified": True},
        {"case": "a", "problem": "non-associative", "method": "y", "multiplier": 0.6, "verified": True},
        {"case": "b", "problem": "non-associative", "method": "x", "multiplier": 0.7, "verified": True},
    ]))
    assert list(df["reference"][:4]) == [0.501, 0.5, 0.6, 0.45]
    assert math.isnan(df["reference"].iloc[4])
    assert df["anomaly"].iloc[0] == "associative-mismatch" and df["anomaly"].iloc[1] == "associative-mismatch"
    # no solution of (3) exceeds the associative multiplier
    assert df["anomaly"].iloc[3] == "above-associative"


def test_marks_say_exactly_what_they_mean():
    rows = pd.DataFrame([
        {"case": "c", "method": "milp", "method_label": "milp", "problem": "non-associative", "repetition": 0,
         "status": "time_limit", "success": False, "verified": True, "multiplier": 0.5},
        {"case": "c", "method": "slp", "method_label": "slp", "problem": "non-associative", "repetition": 0,
         "status": "numerical", "success": False, "verified": False, "multiplier": 0.6},
        {"case": "c", "method": "fixed-point", "method_label": "fixed-point", "problem": "non-associative",
         "repetition": 0, "status": "iteration_limit", "success": False, "verified": True, "multiplier": 0.55},
        {"case": "c", "method": "nlp", "method_label": "nlp", "problem": "non-associative", "repetition": 0,
         "status": "error", "success": False, "verified": False, "multiplier": None},
        {"case": "c", "method": "static-lp", "method_label": "static-lp", "problem": "associative", "repetition": 0,
         "status": "skipped", "success": False, "verified": False, "multiplier": None},
    ])
    assert [cell_mark(r) for _, r in rows.iterrows()] == ["†", "*", "‡", "×", "skip"]
    text = text_table(rows, "multiplier", "{:.2f}", "t")
    assert "0.50†" in text and "0.60*" in text and "0.55‡" in text
    assert "† = verified but not certified" in text and "* = not verified" in text and "skip = skipped" in text


# --------------------------------------------------------------------------- signed errors and new bests (issue 41)

#: synthetic rows, modelled on the issue's wall-10x5 run (nlp's verified 0.505299 below milp's uncertified 0.505815 at
#: its time limit): the comparator's grading is tested on these numbers, not the solvers
WALL_10X5 = [
    {"method": "fixed-point", "multiplier": 0.5061, "verified": True},
    {"method": "nlp", "multiplier": 0.505299, "verified": True},
    {"method": "milp", "multiplier": 0.505815, "verified": True, "certified": False},
]


def test_a_lower_verified_value_than_the_others_is_a_new_best_and_their_reference():
    df = add_references(_frame(WALL_10X5)).set_index("method")
    nlp = df.loc["nlp"]
    assert nlp["new_best"] and nlp["rel_error"] < 0
    assert nlp["reference"] == 0.505815 and nlp["reference_method"] == "milp" and nlp["reference_source"] == "best"
    assert nlp["rel_error"] == pytest.approx((0.505299 - 0.505815) / 0.505815, rel=1e-12)
    assert nlp["abs_rel_error"] == pytest.approx(-nlp["rel_error"], rel=1e-15)
    assert "new best" in nlp["reference_note"] and "this method's own" not in nlp["reference_note"]
    for m in ("fixed-point", "milp"):  # the others are graded against it, with positive errors
        assert df.loc[m, "reference"] == 0.505299 and df.loc[m, "reference_method"] == "nlp"
        assert df.loc[m, "rel_error"] == pytest.approx((df.loc[m, "multiplier"] - 0.505299) / 0.505299, rel=1e-12)
        assert df.loc[m, "rel_error"] > 0 and not df.loc[m, "new_best"]
    assert (df["anomaly"] == "").all()
    rows = df.reset_index().assign(case="c", method_label=lambda d: d["method"], repetition=0,
                                   status=["converged", "locally_optimal", "time_limit"],
                                   success=[True, True, False])
    text = text_table(rows, "multiplier", "{:.6f}", "t", reference=True)
    assert "0.505299↓" in text and "0.505815†" in text and "0.506100" in text
    assert "↓ = new best" in text
    assert "0.50530 (b: nlp)" in text  # the headline reference is the new best


def test_below_by_less_than_the_match_tolerance_is_the_same_answer_not_a_new_best():
    from blockmpec.bench.compare import MATCH_TOL

    lam = 0.5 * (1 - 0.5 * MATCH_TOL)
    df = add_references(_frame([{"method": "a", "multiplier": 0.5, "verified": True},
                                {"method": "b", "multiplier": lam, "verified": True}])).set_index("method")
    assert df.loc["b", "rel_error"] < 0 and not df.loc["b", "new_best"]
    # not verified: never a new best, however low
    df = add_references(_frame([{"method": "a", "multiplier": 0.5, "verified": True},
                                {"method": "b", "multiplier": 0.1, "verified": False}])).set_index("method")
    assert not df.loc["b", "new_best"] and df.loc["b", "rel_error"] == pytest.approx(-0.8)
    # against a closed form a lower verified value is an anomaly, never a new best
    df = add_references(_frame([{"method": "a", "multiplier": 0.2, "verified": True, "closed_form": 0.25}]))
    assert not df["new_best"].iloc[0] and df["anomaly"].iloc[0] == "below-closed-form-minimum"
    assert df["rel_error"].iloc[0] == pytest.approx(-0.2)


def test_the_printed_marks_are_the_rules_of_the_code():
    """Every mark's printed definition names the rule cell_mark / grade_marks apply, in the same words."""
    from blockmpec.bench.compare import FAILED_STATUSES, MARKS, MATCH_TOL, grade_marks

    for status in FAILED_STATUSES:  # × = these statuses whatever the multiplier, or no multiplier
        assert status in MARKS["×"]
        assert cell_mark({"status": status, "multiplier": 0.5, "success": False, "verified": True}) == "×"
    assert cell_mark({"status": "time_limit", "multiplier": None, "success": False, "verified": False}) == "×"
    assert f"{MATCH_TOL:g}" in MARKS["↓"]
    assert grade_marks({"anomaly": "below-certified-minimum", "new_best": False}) == "!"
    assert grade_marks({"anomaly": "", "new_best": True}) == "↓"
    assert grade_marks({"anomaly": "", "new_best": False}) == ""


def test_new_best_in_a_real_run():
    """A real comparison without a closed form or a certificate: on the 4 x 3 running-bond wall the fixed point
    (7/11) lies below mcp-newton from the dead-load start (0.6415508, the associative multiplier, another solution of
    (3)): the fixed point is the new best, with a negative error, and mcp-newton is graded against it.  Both values
    are the independent statement's (references.py: a solution of (3) at 7/11, the least lam of its pattern; the
    static LP's optimum)."""
    df = compare({"w": ("wall", {"courses": 4, "blocks_per_course": 3})},
                 ["fixed-point", ("mcp-newton", {"start": "dead-load"})], progress=False, isolate=False)
    row = df.set_index("method")
    fp, newton = row.loc["fixed-point"], row.loc["mcp-newton"]
    assert fp["verified"] and newton["verified"]
    assert fp["multiplier"] == pytest.approx(WALL_4X3_MINIMUM, rel=1e-9)  # 1.6e-10 below: its tie-break, by design
    assert newton["multiplier"] == pytest.approx(WALL_4X3_ASSOCIATIVE, rel=1e-9)  # 6.2e-14 measured
    assert fp["new_best"] and fp["reference"] == newton["multiplier"] and fp["rel_error"] < -1e-3
    assert not newton["new_best"] and newton["reference"] == fp["multiplier"]
    assert newton["reference_method"] == "fixed-point" and newton["rel_error"] > 1e-3
    from blockmpec.bench.profiles import solved

    assert solved(df).tolist() == [True, False]  # the new best solves the case, the higher point does not


# --------------------------------------------------------------------------- real runs


def test_the_closed_form_is_the_reference_not_the_runs_own_value():
    """The issue's example: static-lp and fixed-point on two blocks; the reference is the closed form 1/3,
    whatever the fixed point returns (it once returned the associative 0.41973 and was graded against itself)."""
    df = compare(TWO_BLOCKS, ["static-lp", ("fixed-point", {"start": "associative", "tie_break": "closest"})],
                 progress=False)
    fp = df.set_index("method").loc["fixed-point"]
    assert fp["reference_source"] == "closed-form" and fp["reference"] == pytest.approx(NA_MIN, rel=1e-12)
    assert fp["rel_error"] == pytest.approx(abs(fp["multiplier"] - NA_MIN) / NA_MIN, rel=1e-9)
    lp = df.set_index("method").loc["static-lp"]
    assert lp["reference_source"] == "closed-form" and lp["rel_error"] < 1e-9


def test_certified_minimum_of_milp_grades_the_others():
    res: dict = {}
    df = compare({"arch": ("round-arch", {"n_voussoirs": 6})}, ["fixed-point", "milp"], results=res, progress=False)
    row = df.set_index("method_label")
    assert row.loc["milp", "status"] == "optimal", row.loc["milp", "message"]
    assert row.loc["milp", "certified"]
    assert row.loc["fixed-point", "reference_source"] == "certified"
    assert row.loc["fixed-point", "reference_method"] == "milp"
    assert row.loc["fixed-point", "reference"] == row.loc["milp", "multiplier"]
    # milp's own certificate is not its reference
    assert row.loc["milp", "reference_method"] != "milp"
    assert set(res) == {("arch", m, 0) for m in ("fixed-point", "milp")}


@pytest.fixture
def dummies():
    import dummy_solvers

    for cls in dummy_solvers.DUMMIES:
        registry.register_solver(cls)
    yield dummy_solvers.NAMES
    for name in dummy_solvers.NAMES:
        registry.unregister_solver(name)


@pytest.mark.slow
def test_crash_hang_exception_and_skip_become_rows_and_the_study_goes_on(dummies, tmp_path):
    methods = [*dummies, "static-lp"]
    df = compare(TWO_BLOCKS, methods, wall_limit={"test-hangs": 4.0}, out=tmp_path / "out", progress=False)
    assert list(df["method"]) == methods
    row = df.set_index("method")
    assert row.loc["test-raises-in-run", "status"] == "error"
    assert "deliberate failure" in row.loc["test-raises-in-run", "message"]
    assert "set-up failed" in row.loc["test-raises-in-setup", "message"]
    assert row.loc["test-never-fits", "status"] == "skipped"
    assert row.loc["test-never-fits", "message"] == "this dummy fits no case"
    assert row.loc["test-escapes-solve", "status"] == "error"
    assert "escaped from solve" in row.loc["test-escapes-solve", "message"]
    assert row.loc["test-segfaults", "status"] == "error"
    assert "SIGSEGV" in row.loc["test-segfaults", "message"]
    assert row.loc["test-hangs", "status"] == "time_limit"
    assert "wall-clock limit of 4 s" in row.loc["test-hangs", "message"]
    assert 4.0 <= row.loc["test-hangs", "wall_time_s"] < 30.0
    for m in dummies:
        assert not row.loc[m, "success"] and pd.isna(row.loc[m, "multiplier"])
        assert row.loc[m, "reference_source"] == "closed-form"
    # the solve after the crash and the hang ran in a fresh worker and succeeded
    assert row.loc["static-lp", "success"]
    assert row.loc["static-lp", "multiplier"] == pytest.approx(ASSOC, rel=EXACT)
    saved = pd.read_csv(tmp_path / "out" / "results.csv")
    assert list(saved["status"]) == list(df["status"])


def test_labels_options_repeat_and_columns(tmp_path):
    assert parametrised_label("fixed-point", {"relaxation": 0.5}) == "fixed-point[relaxation=0.5]"
    with pytest.raises(bm.OptionError, match="no option 'nope'"):
        normalise_methods([("fixed-point", {"nope": 1})])
    df = compare({"sb": ("single-block", {"width": 1.0, "height": 4.0})},
                 ["static-lp", ("fixed-point", {"relaxation": 0.5})], repeat=2, progress=False)
    assert len(df) == 4
    assert list(df["method_label"]) == ["static-lp"] * 2 + ["fixed-point[relaxation=0.5]"] * 2
    assert list(df["repetition"]) == [0, 1, 0, 1]
    assert df["p_case_height"].iloc[0] == 4.0 and df["p_method_relaxation"].iloc[2] == 0.5
    from blockmpec.verify import RESIDUAL_NAMES

    for col in ("case", "case_name", "method", "method_label", "problem", "status", "success", "verified",
                "multiplier", *RESIDUAL_NAMES, "build_time_s", "solve_time_s", "total_time_s", "iterations",
                "wall_time_s", "wall_limit_s", "message", "reference", "reference_source", "reference_method",
                "reference_note", "abs_error", "rel_error", "anomaly", "run_key",
                "signed_error", "abs_rel_error", "new_best", "budget_s", "resumed"):
        assert col in df.columns, col
    from blockmpec.bench.compare import COLUMNS

    # the columns of earlier versions keep their places; the new ones come after them
    assert list(COLUMNS[-5:]) == ["signed_error", "abs_rel_error", "new_best", "budget_s", "resumed"]
    assert COLUMNS.index("run_key") < COLUMNS.index("signed_error")
    assert (df["budget_s"] == df["wall_limit_s"].max()).all() and not df["resumed"].any()
    np.testing.assert_allclose(df["total_time_s"], df["build_time_s"] + df["solve_time_s"])
    # closed form of the single block: lam = min(mu, b/h) = 0.25 for both problems
    np.testing.assert_allclose(df["multiplier"], 0.25, rtol=1e-8)
    assert (df["rel_error"] < 1e-8).all() and set(df["reference_source"]) == {"closed-form"}
    from blockmpec.bench.runner import default_wall_limit

    assert list(df["wall_limit_s"]) == [default_wall_limit({}, "static-lp")] * 2 + [
        default_wall_limit({"relaxation": 0.5}, "fixed-point")] * 2


def test_a_certified_maximum_is_never_the_minimum_reference():
    cases = {"arch": ("round-arch", {"n_voussoirs": 6})}
    both = compare(cases, [("milp", {"sense": "max"}), "milp", "fixed-point"], progress=False)
    row = both.set_index("method_label")
    assert not row.loc["milp[sense=max]", "certified"] and row.loc["milp", "certified"]
    assert row.loc["fixed-point", "reference"] == row.loc["milp", "multiplier"]


# --------------------------------------------------------------------------- output folders


def test_rows_are_saved_as_they_finish_and_resume_skips_them(tmp_path):
    out = tmp_path / "study"
    first = compare(TWO_BLOCKS, ["static-lp"], out=out, progress=False)
    lines = (out / "rows.jsonl").read_text().splitlines()
    assert len(lines) == 1 and json.loads(lines[0])["method"] == "static-lp"
    assert pd.read_parquet(out / "results.parquet")["multiplier"].iloc[0] == pytest.approx(ASSOC, rel=EXACT)
    with pytest.raises(bm.OptionError, match="not empty"):
        compare(TWO_BLOCKS, ["static-lp"], out=out, progress=False)
    res: dict = {}
    again = compare(TWO_BLOCKS, ["static-lp", "kinematic-lp"], out=out, resume=True, results=res, progress=False)
    assert list(again["method"]) == ["static-lp", "kinematic-lp"]
    # the static-lp row is the saved one (same wall time), not a new solve
    assert again["wall_time_s"].iloc[0] == first["wall_time_s"].iloc[0]
    assert len((out / "rows.jsonl").read_text().splitlines()) == 2
    assert ("two-blocks", "static-lp", 0) in res  # its result came back from solutions/ for the figures
    assert again["reference_source"].iloc[0] == "closed-form"
    assert list(again["resumed"]) == [True, False]  # what was kept and what ran now


def test_overwrite_leaves_no_stale_figure_and_a_live_run_locks_the_folder(tmp_path):
    from blockmpec.bench.study import LOCK_NAME, ResultsFolder

    out = tmp_path / "o"
    out.mkdir()
    (out / "mechanism_old-case.png").write_bytes(b"old")
    (out / "results.csv").write_text("old")
    (out / "notes.txt").write_text("mine")
    with pytest.raises(bm.OptionError, match="--overwrite"):
        ResultsFolder(out)
    with ResultsFolder(out, overwrite=True):
        assert sorted(p.name for p in out.iterdir()) == sorted([LOCK_NAME, "notes.txt", "solutions"])
        with pytest.raises(bm.OptionError, match="another blockmpec run"):
            ResultsFolder(out, resume=True)
    assert not (out / LOCK_NAME).exists()
    (out / LOCK_NAME).write_text("999999999")  # a dead process's lock is taken over
    ResultsFolder(out, resume=True).close()
    with pytest.raises(bm.OptionError, match="not a folder"):
        ResultsFolder(tmp_path / "o" / "notes.txt")


def test_metadata_sidecar():
    from blockmpec.bench.study import run_metadata

    meta = run_metadata(["blockmpec", "compare"], {"jobs": 2})
    assert meta["command"] == ["blockmpec", "compare"] and meta["settings"] == {"jobs": 2}
    assert meta["versions"]["numpy"] == np.__version__ and meta["versions"]["blockmpec"]
    assert meta["cpu_count"] == os.cpu_count() and meta["cpu"] and meta["started"].endswith("+00:00")


# --------------------------------------------------------------------------- parallel and distributed


@pytest.mark.slow
def test_two_local_workers_give_the_serial_answers():
    cases = {"two-blocks": TWO_BLOCKS["two-blocks"], "arch": ("round-arch", {"n_voussoirs": 6})}
    serial = compare(cases, ["static-lp", "fixed-point"], progress=False)
    parallel = compare(cases, ["static-lp", "fixed-point"], n_jobs=2, progress=False)
    assert list(parallel["run_key"]) == list(serial["run_key"])  # task order, whatever the finishing order
    np.testing.assert_allclose(parallel["multiplier"], serial["multiplier"], rtol=1e-9)


@pytest.mark.slow
def test_solves_side_by_side_share_the_cpus(monkeypatch):
    """With ``n_jobs`` solves side by side on this machine each may use its share of the CPUs
    (``BLOCKMPEC_CPUS``, read by the block IPM's automatic settings); a serial study leaves the variable as it is,
    here unset, and the comparing process's own environment is unchanged either way."""
    import dummy_solvers

    from blockmpec.bench.runner import CPUS_VARIABLE, shared_cpus, usable_cpus

    monkeypatch.delenv(CPUS_VARIABLE, raising=False)
    registry.register_solver(dummy_solvers.ReportsCpus)
    try:
        for n_jobs, variable, cpus in ((1, None, usable_cpus()), (2, str(shared_cpus(2)), shared_cpus(2))):
            results = {}
            compare(TWO_BLOCKS, ["test-reports-cpus"], repeat=2, n_jobs=n_jobs, results=results, progress=False)
            assert len(results) == 2
            for res, _ in results.values():
                assert res.extra["cpus_variable"] == variable and res.extra["usable_cpus"] == cpus, n_jobs
    finally:
        registry.unregister_solver("test-reports-cpus")
    assert CPUS_VARIABLE not in os.environ
    assert shared_cpus(2) == max(1, usable_cpus() // 2) and shared_cpus(10_000) == 1


def test_cpus_variable_caps_the_automatic_settings(monkeypatch):
    """``BLOCKMPEC_CPUS`` caps what the block IPM's ``"auto"`` counts (it reads ``usable_cpus``); a bad value is one
    clear error naming the variable."""
    from blockmpec.bench.runner import CPUS_VARIABLE, cpu_budget, usable_cpus
    from blockmpec.solvers.linalg import block_ipm, cholesky
    from blockmpec.solvers.linalg import cpus as linalg_cpus

    assert block_ipm.usable_cpus is linalg_cpus.usable_cpus and cholesky.usable_cpus is linalg_cpus.usable_cpus

    monkeypatch.delenv(CPUS_VARIABLE, raising=False)
    cpus = usable_cpus()
    assert cpu_budget() is None
    monkeypatch.setenv(CPUS_VARIABLE, "1")
    assert cpu_budget() == 1 and usable_cpus() == 1
    monkeypatch.setenv(CPUS_VARIABLE, str(cpus + 5))
    assert usable_cpus() == cpus  # a cap, never more than the process may run on
    for bad in ("0", "-2", "two", "1.5"):
        monkeypatch.setenv(CPUS_VARIABLE, bad)
        with pytest.raises(bm.OptionError, match=f"{CPUS_VARIABLE}='{bad}': expected a positive whole number of CPUs"):
            usable_cpus()
    # a study checks it before it starts, as it checks its other options
    with pytest.raises(bm.OptionError, match=f"{CPUS_VARIABLE}='1.5'"):
        compare(TWO_BLOCKS, ["static-lp"], n_jobs=2, progress=False)


@pytest.mark.slow
def test_two_worker_dask_local_cluster():
    pytest.importorskip("distributed")
    cases = {"two-blocks": TWO_BLOCKS["two-blocks"], "sb": ("single-block", {})}
    df = compare(cases, ["static-lp", "kinematic-lp"], n_jobs=2, backend="dask", progress=False)
    assert df["success"].all()
    # the closed forms: 1 / 2.3825 (paper Sect. 3) and the single block's b/h = 1/2
    np.testing.assert_allclose(df["multiplier"], [ASSOC, ASSOC, 0.5, 0.5], rtol=EXACT)


@pytest.mark.slow
def test_an_existing_dask_cluster_by_its_scheduler_address():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=2, processes=True, dashboard_address=None,
                                  silence_logs=40) as cluster:
        df = compare({"sb": ("single-block", {"height": 4.0})}, ["static-lp", "kinematic-lp", "fixed-point"],
                     backend="dask", scheduler=cluster.scheduler_address, progress=False)
    np.testing.assert_allclose(df["multiplier"], 0.25, rtol=1e-8)


def test_bad_backend_settings_are_option_errors():
    with pytest.raises(bm.OptionError, match="backend"):
        compare(TWO_BLOCKS, ["static-lp"], backend="threads")
    with pytest.raises(bm.OptionError, match="jobs"):
        compare(TWO_BLOCKS, ["static-lp"], n_jobs=0)
    with pytest.raises(bm.OptionError, match="scheduler"):
        compare(TWO_BLOCKS, ["static-lp"], scheduler="tcp://127.0.0.1:1")
    with pytest.raises(bm.OptionError, match="verify_tol"):
        compare(TWO_BLOCKS, ["static-lp"], verify_tol=float("nan"))
    with pytest.raises(bm.OptionError, match="wall limit"):
        compare(TWO_BLOCKS, ["static-lp"], wall_limit=-1)


def test_progress_shows_the_running_solve_its_elapsed_time_and_failures(tmp_path):
    import io
    import time

    from blockmpec.bench.compare import Progress

    bar = Progress(3, {7: "arch · milp"}, str(tmp_path), enabled=True)
    stream = io.StringIO()
    bar.bar.fp = stream
    (tmp_path / "7.start").write_text(repr(time.time() - 12.0))  # a supervisor started task 7 twelve seconds ago
    assert bar.running()[0][1] == "arch · milp" and 12.0 <= bar.running()[0][0] < 60.0
    assert bar.postfix().startswith("running arch · milp 12s") and bar.postfix().endswith("failed 0")
    bar.finished({"status": "error"})
    bar.finished({"status": "optimal"})
    assert bar.failed == 1 and bar.bar.n == 2 and "failed 1" in bar.postfix()
    bar.close()


def test_outside_wall_limit_leaves_room_for_the_methods_own_time_limit():
    """A method run with its default time_limit must report time_limit itself before the runner kills it; the
    default is the one of CommonOptions, and time_limit=inf (no limit) means no outside limit either."""
    from blockmpec.bench.runner import DEFAULT_WALL_LIMIT_S, default_wall_limit
    from blockmpec.options import DEFAULT_TIME_LIMIT_S

    assert DEFAULT_WALL_LIMIT_S == max(1.5 * DEFAULT_TIME_LIMIT_S, DEFAULT_TIME_LIMIT_S + 30.0)
    for method in bm.list_solvers():
        t = registry.get_solver(method)().options.time_limit  # the default every method runs with
        assert t == DEFAULT_TIME_LIMIT_S, method
        assert default_wall_limit({}, method) == max(1.5 * t, t + 30.0) == DEFAULT_WALL_LIMIT_S
        assert default_wall_limit({"time_limit": math.inf}, method) == math.inf
    assert default_wall_limit({"time_limit": 10.0}, "milp") == 40.0  # a given limit wins over the default
    assert default_wall_limit({"time_limit": 100.0}, "milp") == 150.0
    df = compare(TWO_BLOCKS, [("static-lp", {"time_limit": math.inf})], progress=False, isolate=False)
    assert df["wall_limit_s"].iloc[0] == math.inf and df["success"].all()


# --------------------------------------------------------------------------- budgets and engine settings


def test_one_budget_per_case_given_or_the_largest_wall_limit():
    from blockmpec.bench.profiles import case_budgets

    df = compare(TWO_BLOCKS, ["static-lp", ("milp", {"time_limit": 30.0})], progress=False, isolate=False)
    assert list(df["wall_limit_s"]) == [900.0, 60.0] and list(df["budget_s"]) == [900.0, 900.0]
    assert case_budgets(df) == {"two-blocks": 900.0} and case_budgets(df, 5.0) == {"two-blocks": 5.0}
    df = compare(TWO_BLOCKS, ["static-lp"], budget={"two-blocks": 7.0}, progress=False, isolate=False)
    assert list(df["budget_s"]) == [7.0]
    with pytest.raises(bm.OptionError, match="budget: must be a finite number of seconds > 0"):
        compare(TWO_BLOCKS, ["static-lp"], budget=-1.0, progress=False)
    with pytest.raises(bm.OptionError, match="no case 'nope'"):
        compare(TWO_BLOCKS, ["static-lp"], budget={"nope": 1.0}, progress=False)


def test_a_method_with_engine_settings_runs_through_run_solver():
    """Experiments compare engine settings: (label, method, options, settings) runs the configured instance."""
    from blockmpec.solvers.fixed_point import FixedPointSettings

    settings = FixedPointSettings(acceleration="anderson")
    df = compare(TWO_BLOCKS, ["fixed-point", ("fp-anderson", "fixed-point", {}, settings)], progress=False)
    assert df["success"].all() and list(df["method_label"]) == ["fixed-point", "fp-anderson"]
    np.testing.assert_allclose(df["multiplier"], NA_MIN, rtol=1e-8)
    assert df["run_key"].iloc[0] != df["run_key"].iloc[1]
    with pytest.raises(bm.OptionError, match="settings must be a FixedPointSettings"):
        compare(TWO_BLOCKS, [("x", "fixed-point", {}, object())], progress=False)

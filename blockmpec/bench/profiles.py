r"""Summaries of a comparison for papers: Dolan--Moré performance profiles and a summary table.

Budget
------
Every case has one time budget ``B_p`` [s] (column ``budget_s`` of the comparison table,
:func:`case_budgets`), the same for every method of the case: by default the largest finite
wall-clock limit of the case's runs (``wall_limit_s``; the largest wall time of its runs when none
is finite), or a value the user sets (``compare(..., budget=)``, ``blockmpec compare --budget``).

Solved
------
A run *solves* its case when (:func:`solved`, stated by :data:`SOLVED_DEFINITION`)

1. it is verified (every residual of (3) within the tolerance) with a finite multiplier,
2. its solve time is at most the case's budget (``solve_time_s <= budget_s``), and
3. its multiplier matches the reference (``rel_error = (lam - lam_ref) / |lam_ref|`` of
   :func:`blockmpec.bench.compare.add_references`): ``|rel_error| <= tol`` against an exact
   reference (closed form, certified minimum, and every associative reference), and
   ``rel_error <= tol`` against a non-associative reference of source ``best`` (the smallest
   verified value of another method, an upper bound on the minimum of (4)): a lower verified
   value there is a better answer (a new best), not an error.  A row with no reference
   (``reference_source`` ``none``) meets this rule.

``tol`` = :data:`SOLVED_TOL` = :data:`blockmpec.bench.compare.MATCH_TOL`.

Performance profile (Dolan & Moré 2002)
---------------------------------------
For the set ``P`` of cases and the set ``S`` of methods answering one problem
(associative or non-associative, profiled apart), with ``t_{p,s}`` the median solve
time of method ``s`` on case ``p`` over repetitions (``inf`` when a repetition does not solve it),

.. math:: r_{p,s} = t_{p,s} / \min_{s'} t_{p,s'}, \qquad
          \rho_s(\tau) = |\{p \in P : r_{p,s} \le \tau\}| \,/\, |P|,

the fraction of cases that ``s`` solves within ``τ`` times the best time.
``ρ_s(1)`` is the share of cases where ``s`` is fastest, ``ρ_s(∞)`` its success rate.
The budget enters through "solved": a run over its case's budget is not solved, so every
method of a case is held to the same time.
Times below :data:`TIME_FLOOR_S` are raised to it (timer resolution).  The packages
listed for this (``perfprof``, last release 2021; ``optiprofiler``, which runs
derivative-free solvers itself) do not fit a table of finished runs, so this is
a short own implementation.

Summary table (qpbenchmark style)
---------------------------------
Per method: runs, solved, success rate, the shifted geometric mean of the solve time

.. math:: \mathrm{sgm}_s = \exp\Big(\frac1n \sum_i \log(t_i + \sigma)\Big) - \sigma,

over *every* run, ``t_i`` the solve time of a solved run and the case's budget ``B_p`` for an
unsolved one (one budget per case, the same for every method), with shift ``σ =``
:data:`SHIFT_S`, then divided by the smallest ``sgm`` among the methods of the same problem
(the best method reads 1.0); and the median signed relative error ``rel_error`` over the runs
that have one (negative: below the reference).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from blockmpec import OptionError
from blockmpec.bench.runs import MATCH_TOL, _finite, _true, relative_error

#: shift of the shifted geometric mean of times [s] (our solves take milliseconds to minutes)
SHIFT_S = 0.01
#: times below this are raised to it in the profiles [s]
TIME_FLOOR_S = 1e-4
#: relative tolerance on the multiplier for a run to count as solved
SOLVED_TOL = MATCH_TOL


def solved_definition(tol: float = SOLVED_TOL) -> str:
    """The definition of "solved" that :func:`solved` implements, as printed under the summary."""
    return (f"solved = verified, solve time <= the case's budget, and rel_error = (lam - reference)/|reference| "
            f"within {tol:g}: |rel_error| <= {tol:g} against an exact reference (closed form, certified minimum, "
            f"associative), rel_error <= {tol:g} against the best verified value of another method "
            "(lower is a new best); no reference: verified is enough")


#: the definition of "solved" (:func:`solved`), word for word as ``blockmpec compare`` prints it
SOLVED_DEFINITION = solved_definition()


def check_budget(budget: Any, cases: list[str] | None = None) -> float | dict[str, float] | None:
    """A budget argument (None, seconds, or case label -> seconds), checked: OptionError naming what is wrong."""
    if budget is None:
        return None
    if isinstance(budget, Mapping):
        out = {}
        for case, value in budget.items():
            if cases is not None and case not in cases:
                raise OptionError(f"budget {case}=...: no case {case!r} in this run; cases: {', '.join(cases)}")
            out[str(case)] = _seconds(value, f"budget of {case}")
        return out
    return _seconds(budget, "budget")


def _seconds(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (value > 0 and math.isfinite(value)):
        raise OptionError(f"{where}: must be a finite number of seconds > 0; got {value!r}")
    return float(value)


def case_budgets(df, budget: float | Mapping[str, float] | None = None) -> dict[str, float]:
    """The time budget of each case of a comparison table (see the module docstring).

    Parameters
    ----------
    df : pandas.DataFrame
        Rows with ``case`` and ``wall_limit_s`` (and ``wall_time_s`` for the fallback).
    budget : float or mapping, optional
        One budget for every case, or case label -> seconds (cases not in it take the default).

    Returns
    -------
    dict
        Case label -> budget [s]: the given value, else the largest finite ``wall_limit_s`` of the case's
        rows, else the largest finite ``wall_time_s``, else NaN.
    """
    budget = check_budget(budget)
    out: dict[str, float] = {}
    if not len(df):
        return out
    for case, grp in df.groupby("case", sort=False):
        if isinstance(budget, float):
            out[case] = budget
            continue
        if isinstance(budget, dict) and case in budget:
            out[case] = budget[case]
            continue
        limits = [float(v) for v in grp.get("wall_limit_s", []) if _finite(v) and float(v) > 0]
        if not limits:
            limits = [float(v) for v in grp.get("wall_time_s", []) if _finite(v) and float(v) > 0]
        out[case] = max(limits) if limits else math.nan
    return out


def _budgets_of(df, budget) -> dict[str, float]:
    """The budgets to apply: ``budget`` if given, else the table's ``budget_s`` column, else the default."""
    if budget is None and "budget_s" in df.columns and len(df):
        given = {c: float(v) for c, v in zip(df["case"], df["budget_s"]) if _finite(v)}
        if given:
            return {**case_budgets(df), **given}
    return case_budgets(df, budget)


def solved(df, tol: float = SOLVED_TOL, budget: float | Mapping[str, float] | None = None) -> np.ndarray:
    """Boolean per row of a comparison table: does the run solve its case (see the module docstring)?

    ``budget``: as for :func:`case_budgets`; None takes the table's ``budget_s`` column, else the default.
    A table without ``solve_time_s`` is not held to a budget.
    """
    budgets = _budgets_of(df, budget) if "case" in df.columns else {}
    out = np.zeros(len(df), dtype=bool)
    for i, (_, r) in enumerate(df.iterrows()):
        if not _true(r.get("verified")) or not _finite(r.get("multiplier")):
            continue
        limit = budgets.get(r.get("case"), math.nan)
        t = r.get("solve_time_s")
        if _finite(limit) and _finite(t) and float(t) > limit:
            continue
        ref = r.get("reference")
        if not _finite(ref):
            out[i] = True
            continue
        rel = relative_error(float(r["multiplier"]), float(ref))
        if r.get("problem") == "non-associative" and r.get("reference_source") == "best":
            out[i] = rel <= tol
        else:
            out[i] = abs(rel) <= tol
    return out


def profile_data(df, tol: float = SOLVED_TOL, budget: float | Mapping[str, float] | None = None
                 ) -> dict[str, dict[str, Any]]:
    """Performance-profile ratios per problem: ``{problem: {"cases": [...], "ratios": {method_label: array},
    "budgets": {case: seconds}}}`` (``inf`` ratio: not solved within the case's budget)."""
    df = df.copy()
    df["_solved"] = solved(df, tol, budget)
    budgets = _budgets_of(df, budget)
    out: dict[str, dict[str, Any]] = {}
    for problem in ("associative", "non-associative"):
        sub = df[df["problem"] == problem]
        if not len(sub):
            continue
        cases = list(dict.fromkeys(sub["case"]))
        methods = list(dict.fromkeys(sub["method_label"]))
        t = np.full((len(cases), len(methods)), np.inf)
        for (case, label), grp in sub.groupby(["case", "method_label"], sort=False):
            if grp["_solved"].all():
                times = [max(float(v), TIME_FLOOR_S) for v in grp["solve_time_s"] if _finite(v)]
                if times:
                    t[cases.index(case), methods.index(label)] = float(np.median(times))
        best = t.min(axis=1, keepdims=True)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratios = np.where(np.isfinite(best), t / best, np.inf)
        out[problem] = {"cases": cases, "ratios": {m: ratios[:, j] for j, m in enumerate(methods)},
                        "budgets": {c: budgets.get(c, math.nan) for c in cases}}
    return out


def rho(ratios: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """``ρ(τ)``: the fraction of cases with ratio ``<= τ``, for each ``τ``."""
    ratios = np.asarray(ratios, float)
    return np.array([(ratios <= t).mean() if ratios.size else 0.0 for t in np.atleast_1d(tau)])


def summary_table(df, tol: float = SOLVED_TOL, shift: float = SHIFT_S,
                  budget: float | Mapping[str, float] | None = None):
    """One row per method label: ``method, problem, runs, solved, success_rate, sgm_time_s, sgm_time_ratio,
    median_rel_error`` (signed), ``charged_runs`` (unsolved runs, charged their case's budget) and
    ``median_abs_rel_error``.

    ``budget``: as for :func:`case_budgets`; None takes the table's ``budget_s`` column, else the default.
    """
    import pandas as pd

    df = df.copy()
    df["_solved"] = solved(df, tol, budget)
    budgets = _budgets_of(df, budget)
    rows = []
    for label, grp in df.groupby("method_label", sort=False):
        times = []
        for _, r in grp.iterrows():
            if r["_solved"]:
                t = max(float(r["solve_time_s"]), 0.0) if _finite(r.get("solve_time_s")) else math.nan
            else:
                t = budgets.get(r["case"], math.nan)
            if math.isfinite(t):
                times.append(t)
        sgm = math.exp(np.mean(np.log(np.asarray(times) + shift))) - shift if times else math.nan
        errs = [float(v) for v in grp["rel_error"] if _finite(v)]
        rows.append({"method": label, "problem": grp["problem"].iloc[0], "runs": len(grp),
                     "solved": int(grp["_solved"].sum()), "success_rate": float(grp["_solved"].mean()),
                     "sgm_time_s": sgm, "median_rel_error": float(np.median(errs)) if errs else math.nan,
                     "charged_runs": int((~grp["_solved"]).sum()),
                     "median_abs_rel_error": float(np.median(np.abs(errs))) if errs else math.nan})
    table = pd.DataFrame(rows)
    if len(table):  # associative methods first, each problem in the order the methods appear in the table
        first = {label: i for i, label in reversed(list(enumerate(df["method_label"])))}
        table["_order"] = [(p != "associative", first[m]) for p, m in zip(table["problem"], table["method"])]
        table = table.sort_values("_order", kind="stable").drop(columns="_order").reset_index(drop=True)
        best = table.groupby("problem")["sgm_time_s"].transform("min")
        table.insert(6, "sgm_time_ratio", table["sgm_time_s"] / best)
    table.attrs["budgets"] = budgets
    table.attrs["budget_given"] = budget is not None
    return table


def budget_text(budgets: Mapping[str, float], given: bool = False) -> str:
    """One line naming the budget of every case, e.g. ``budget per case (the largest wall-clock limit of the
    case's runs): wall-10x5 900 s, two-blocks 900 s``."""
    how = "set by the user" if given else "the largest wall-clock limit of the case's runs"
    parts = [f"{case} {value:g} s" for case, value in budgets.items()]
    return f"budget per case ({how}; the same for every method of a case): " + ", ".join(parts)


def summary_text(table, tol: float = SOLVED_TOL, shift: float = SHIFT_S) -> str:
    """The summary table as text, with the definition of "solved" (:data:`SOLVED_DEFINITION`) and the budget of
    every case (:func:`budget_text`)."""
    lines = ["Summary",
             solved_definition(tol),
             f"time: shifted geometric mean of the solve time (shift {shift:g} s) over every run, an unsolved run "
             "charged its case's budget; x best: 1.0 = the best method of the problem",
             budget_text(table.attrs.get("budgets", {}), bool(table.attrs.get("budget_given")))]
    head = (f"{'method':<26}{'problem':<17}{'solved':>9}{'rate':>7}{'sgm time [s]':>14}{'x best':>9}"
            f"{'median error':>14}")
    lines.append(head)
    for _, r in table.iterrows():
        err = "–" if not _finite(r["median_rel_error"]) else f"{r['median_rel_error']:+.1e}"
        lines.append(f"{r['method']:<26}{r['problem']:<17}{f'{r.solved}/{r.runs}':>9}{r['success_rate']:>7.0%}"
                     f"{r['sgm_time_s']:>14.3g}{r['sgm_time_ratio']:>9.3g}{err:>14}")
    lines.append("median error: the median signed rel_error of the method's runs (negative: below the reference)")
    return "\n".join(lines)

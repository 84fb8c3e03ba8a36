r"""Summaries of a comparison for papers: Dolan--Moré performance profiles and a summary table.

Solved
------
A run *solves* its case when it is verified (every residual of (3) within the
tolerance) and its multiplier is within ``tol`` (relative) of the row's reference
(``rel_error`` of :func:`blockmpec.bench.compare.compare`).  For a non-associative row whose
reference is not exact (source ``best``: the smallest verified value of another
method, an upper bound on the minimum of (4)) a verified multiplier *below* the
reference also solves the case: it is a better answer, not an error.  A row with no
reference is solved when it is verified.

Performance profile (Dolan & Moré 2002)
---------------------------------------
For the set ``P`` of cases and the set ``S`` of methods answering one problem
(associative or non-associative, profiled apart), with ``t_{p,s}`` the median solve
time of method ``s`` on case ``p`` over repetitions (``inf`` when not solved),

.. math:: r_{p,s} = t_{p,s} / \min_{s'} t_{p,s'}, \qquad
          \rho_s(\tau) = |\{p \in P : r_{p,s} \le \tau\}| \,/\, |P|,

the fraction of cases that ``s`` solves within ``τ`` times the best time.
``ρ_s(1)`` is the share of cases where ``s`` is fastest, ``ρ_s(∞)`` its success rate.
Times below :data:`TIME_FLOOR_S` are raised to it (timer resolution).  The packages
listed for this (``perfprof``, last release 2021; ``optiprofiler``, which runs
derivative-free solvers itself) do not fit a table of finished runs, so this is
a short own implementation.

Summary table (qpbenchmark style)
---------------------------------
Per method: runs, solved, success rate, the shifted geometric mean of the solve time

.. math:: \mathrm{sgm}_s = \exp\Big(\frac1n \sum_i \log(t_i + \sigma)\Big) - \sigma,

over *every* run, an unsolved run charged its wall-clock limit (``wall_limit_s``),
with shift ``σ =`` :data:`SHIFT_S`, then divided by the smallest ``sgm`` among the
methods of the same problem (the best method reads 1.0), and the median relative
error over the runs that have one.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from blockmpec.result import is_finite_number as _finite

#: shift of the shifted geometric mean of times [s] (our solves take milliseconds to minutes)
SHIFT_S = 0.01
#: times below this are raised to it in the profiles [s]
TIME_FLOOR_S = 1e-4
#: relative tolerance on the multiplier for a run to count as solved
SOLVED_TOL = 1e-6


def solved(df, tol: float = SOLVED_TOL) -> np.ndarray:
    """Boolean per row of a comparison table: does the run solve its case (see the module docstring)?"""
    out = np.zeros(len(df), dtype=bool)
    for i, (_, r) in enumerate(df.iterrows()):
        if not bool(r.get("verified")) or not _finite(r.get("multiplier")):
            continue
        ref = r.get("reference")
        if not _finite(ref):
            out[i] = True
            continue
        lam, ref = float(r["multiplier"]), float(ref)
        scale = max(abs(ref), 1e-12)
        if r.get("problem") == "non-associative" and r.get("reference_source") == "best":
            out[i] = (lam - ref) / scale <= tol
        else:
            out[i] = abs(lam - ref) / scale <= tol
    return out


def profile_data(df, tol: float = SOLVED_TOL) -> dict[str, dict[str, Any]]:
    """Performance-profile ratios per problem: ``{problem: {"cases": [...], "ratios": {method_label: array}}}``."""
    df = df.copy()
    df["_solved"] = solved(df, tol)
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
        out[problem] = {"cases": cases, "ratios": {m: ratios[:, j] for j, m in enumerate(methods)}}
    return out


def rho(ratios: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """``ρ(τ)``: the fraction of cases with ratio ``<= τ``, for each ``τ``."""
    ratios = np.asarray(ratios, float)
    return np.array([(ratios <= t).mean() if ratios.size else 0.0 for t in np.atleast_1d(tau)])


def summary_table(df, tol: float = SOLVED_TOL, shift: float = SHIFT_S):
    """One row per method label: problem, runs, solved, success_rate, sgm_time_s, sgm_time_ratio, median_rel_error."""
    import pandas as pd

    df = df.copy()
    df["_solved"] = solved(df, tol)
    rows = []
    for label, grp in df.groupby("method_label", sort=False):
        times = []
        for _, r in grp.iterrows():
            t = float(r["solve_time_s"]) if _finite(r.get("solve_time_s")) else math.nan
            if not r["_solved"]:
                limit = r.get("wall_limit_s")
                t = float(limit) if _finite(limit) else (t if math.isfinite(t) else math.nan)
            if math.isfinite(t):
                times.append(t)
        sgm = math.exp(np.mean(np.log(np.asarray(times) + shift))) - shift if times else math.nan
        errs = [float(v) for v in grp["rel_error"] if _finite(v)]
        rows.append({"method": label, "problem": grp["problem"].iloc[0], "runs": len(grp),
                     "solved": int(grp["_solved"].sum()), "success_rate": float(grp["_solved"].mean()),
                     "sgm_time_s": sgm, "median_rel_error": float(np.median(errs)) if errs else math.nan})
    table = pd.DataFrame(rows)
    if len(table):  # associative methods first, each problem in the order the methods appear in the table
        first = {label: i for i, label in reversed(list(enumerate(df["method_label"])))}
        table["_order"] = [(p != "associative", first[m]) for p, m in zip(table["problem"], table["method"])]
        table = table.sort_values("_order", kind="stable").drop(columns="_order").reset_index(drop=True)
        best = table.groupby("problem")["sgm_time_s"].transform("min")
        table.insert(6, "sgm_time_ratio", table["sgm_time_s"] / best)
    return table


def summary_text(table, tol: float = SOLVED_TOL, shift: float = SHIFT_S) -> str:
    """The summary table as text (one block per problem)."""
    lines = [f"Summary (solved = verified and |lam - reference| <= {tol:g} |reference|; time: shifted geometric mean, "
             f"shift {shift:g} s, unsolved runs charged their wall-clock limit, 1.0 = best method of the problem)"]
    head = f"{'method':<26}{'problem':<17}{'solved':>9}{'rate':>7}{'sgm time [s]':>14}{'x best':>9}{'median error':>14}"
    lines.append(head)
    for _, r in table.iterrows():
        err = "–" if not _finite(r["median_rel_error"]) else f"{r['median_rel_error']:.1e}"
        lines.append(f"{r['method']:<26}{r['problem']:<17}{f'{r.solved}/{r.runs}':>9}{r['success_rate']:>7.0%}"
                     f"{r['sgm_time_s']:>14.3g}{r['sgm_time_ratio']:>9.3g}{err:>14}")
    return "\n".join(lines)


def plot_profiles(df, path: str | Path, tol: float = SOLVED_TOL) -> Path:
    """Dolan--Moré performance profiles, one panel per problem, in the methods' fixed styles."""
    from blockmpec.bench.plots import _pyplot, _save, method_style

    plt = _pyplot()
    data = profile_data(df, tol)
    problems = [p for p in ("associative", "non-associative") if p in data]
    fig, axes = plt.subplots(1, max(len(problems), 1), figsize=(5.2 * max(len(problems), 1), 4.0), squeeze=False,
                             layout="constrained")
    for ax, problem in zip(axes[0], problems):
        ratios = data[problem]["ratios"]
        finite = [r[np.isfinite(r)] for r in ratios.values()]
        top = max([float(f.max()) for f in finite if f.size] + [2.0]) * 1.5
        tau = np.geomspace(1.0, top, 400)
        for label, r in ratios.items():
            colour, marker = method_style(label)
            y = rho(r, tau)
            ax.step(tau, y, where="post", color=colour, lw=1.4, label=label)
            ax.plot(tau[::80], y[::80], ls="", marker=marker, color=colour, ms=5)
        ax.set_xscale("log", base=2)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlim(1.0, top)
        ax.set_xlabel(r"$\tau$ (time within $\tau\times$ the fastest solved run)")
        ax.set_ylabel(r"$\rho(\tau)$: fraction of cases solved")
        ax.set_title(f"{problem} problem ({len(data[problem]['cases'])} cases)")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower right", frameon=False)
    if not problems:
        axes[0, 0].text(0.5, 0.5, "no runs", ha="center", transform=axes[0, 0].transAxes)
    fig.suptitle(f"Performance profiles (solved: verified, multiplier within {tol:g} of the reference)")
    return _save(fig, path)



"""Fixed-point strategies (starts, tie-breaks, relaxation, Anderson), mcp-newton and slp on the heuristic suite.

Every strategy runs on every structure of ``studies/lab/heuristic_suite.py``; each
result goes through the shared verifier (``Result.success``).  The reference of a
structure is its certified minimum of (4) (closed form or ``milp``), or for the
large walls the lowest verified multiplier of the run.  Per strategy the table gives:

* ``verified``: share of the structures where the run is verified;
* ``<=1%``, ``<=2%``: share verified *and* within 1 % / 2 % of the reference;
* ``<=2% below assoc``: the same, over the certified structures whose minimum lies
  below the associative multiplier (the issue's target population);
* ``large``: verified runs on the large walls, and those within 2 % of the best;
* ``median rel err``: median of ``(lam - ref)/ref`` over verified runs (all certified
  structures, and those below the associative multiplier); ``max rel err`` its maximum;
* ``below cert``: verified runs below a certificate by more than 1e-7 (must be 0);
* ``max fric adm``: the worst friction admissibility error of a verified run;
* ``median time``: median solve time [s] over all runs.

Use ``python studies/lab/fixed_point_strategies.py [--only LABEL,...] [--no-large] [--first N]``;
writes ``studies/output/fixed_point_strategies/{runs.csv,table.md}``.  The
certificates come from the cache of ``heuristic_suite.py`` (run it first; missing
ones are computed with ``--time-limit``).
"""

from __future__ import annotations

import argparse
import csv
import math
import statistics
import sys
import time
from pathlib import Path

import blockmpec as bm

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _methods import solve  # noqa: E402
from heuristic_suite import certificate, suite  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "fixed_point_strategies"

FP = "fixed-point"
#: (label, method, options and engine settings: ``_methods.solve`` sends each where it belongs)
STRATEGIES: list[tuple[str, str, dict]] = [
    ("fp associative/closest (old default)", FP, {"start": "associative", "tie_break": "closest"}),
    ("fp associative/none", FP, {"start": "associative", "tie_break": "none"}),
    ("fp associative/least-compressed", FP, {"start": "associative", "tie_break": "least-compressed"}),
    ("fp associative/min-lambda", FP, {"start": "associative", "tie_break": "min-lambda"}),
    ("fp zero/closest", FP, {"start": "zero", "tie_break": "closest"}),
    ("fp zero/least-compressed", FP, {"start": "zero", "tie_break": "least-compressed"}),
    ("fp zero/min-lambda", FP, {"start": "zero", "tie_break": "min-lambda"}),
    ("fp zero/none", FP, {"start": "zero", "tie_break": "none"}),
    ("fp dead-load/closest", FP, {"start": "dead-load", "tie_break": "closest"}),
    ("fp dead-load/least-compressed", FP, {"start": "dead-load", "tie_break": "least-compressed"}),
    ("fp dead-load/min-lambda", FP, {"start": "dead-load", "tie_break": "min-lambda"}),
    ("fp dead-load/on-oscillation", FP, {"start": "dead-load", "tie_break": "on-oscillation"}),
    ("fp dead-load/none", FP, {"start": "dead-load", "tie_break": "none"}),
    *[(f"fp random(seed={s})/least-compressed", FP, {"start": "random", "seed": s, "tie_break": "least-compressed"})
      for s in (0, 1, 2)],
    ("fp random(seed=0)/min-lambda", FP, {"start": "random", "seed": 0, "tie_break": "min-lambda"}),
    ("fp dead-load/least-compressed, relax 0.5", FP,
     {"start": "dead-load", "tie_break": "least-compressed", "relaxation": 0.5}),
    ("fp dead-load/least-compressed, Anderson", FP,
     {"start": "dead-load", "tie_break": "least-compressed", "acceleration": "anderson"}),
    ("fp associative/min-lambda, Anderson", FP,
     {"start": "associative", "tie_break": "min-lambda", "acceleration": "anderson"}),
    ("fp associative/least-compressed, Anderson", FP,
     {"start": "associative", "tie_break": "least-compressed", "acceleration": "anderson"}),
    ("fp dead-load/least-compressed, folded 1e-4", FP,
     {"start": "dead-load", "tie_break": "least-compressed", "fold_weight": 1e-4}),
    ("fp associative/min-lambda, folded 1e-4", FP,
     {"start": "associative", "tie_break": "min-lambda", "fold_weight": 1e-4}),
    ("fp associative/min-lambda, multistart 3", FP,
     {"start": "associative", "tie_break": "min-lambda", "multistart": 3}),
    ("fp dead-load/least-compressed, multistart 3", FP,
     {"start": "dead-load", "tie_break": "least-compressed", "multistart": 3}),
    ("fp interior, aim 0.1 (engine=interior)", FP, {"engine": "interior"}),
    ("fp interior, aim 0.03", FP, {"engine": "interior", "interior_weight": 0.03}),
    ("fp interior, no aim", FP, {"engine": "interior", "interior_weight": 0.0}),
    ("mcp-newton (continuation)", "mcp-newton", {}),
    ("mcp-newton (no continuation)", "mcp-newton", {"continuation": False}),
    ("slp alpha=0.01 beta=0.6 (Gilbert)", "slp", {"alpha": 0.01, "beta": 0.6}),
    ("slp alpha=0.01 halving, beta=0.6", "slp", {"alpha": 0.01, "beta": 0.6, "alpha_schedule": "halving"}),
    ("slp alpha=0.1 halving, beta=0.6", "slp", {"alpha": 0.1, "beta": 0.6, "alpha_schedule": "halving"}),
    ("slp alpha=0.01 beta=0.6, min-lambda tie-break", "slp", {"alpha": 0.01, "beta": 0.6, "tie_break": "min-lambda"}),
    ("slp alpha=0 beta=0.6", "slp", {"alpha": 0.0, "beta": 0.6}),
]


def run_all(strategies, entries, time_limit: float) -> list[dict]:
    rows = []
    for entry in entries:
        structure = entry.build()
        ops = bm.assemble(structure)
        lam_assoc = bm.solve(ops, "static-lp").multiplier
        ref = certificate(entry, compute=False)
        for label, method, options in strategies:
            opts = dict(options)
            opts.setdefault("time_limit", time_limit)
            t0 = time.perf_counter()
            res = solve(ops, method, **opts)
            rows.append({
                "structure": entry.label, "family": entry.family, "strategy": label,
                "reference": ref["value"], "reference_source": ref["source"], "certified": ref["certified"],
                "associative": lam_assoc, "multiplier": res.multiplier, "status": res.status.value,
                "verified": bool(res.success), "iterations": res.iterations,
                "friction_admissibility": res.residuals.get("friction_admissibility", math.nan),
                "solve_time_s": res.solve_time_s, "wall_s": time.perf_counter() - t0,
            })
        print(f"  {entry.label}: done", file=sys.stderr, flush=True)
    # large structures: the best verified value of the run is their reference
    for structure in {r["structure"] for r in rows if r["reference_source"] == "best verified"}:
        mine = [r for r in rows if r["structure"] == structure]
        best = min((r["multiplier"] for r in mine if r["verified"]), default=None)
        for r in mine:
            r["reference"] = best
    for r in rows:
        ok = r["verified"] and r["reference"] not in (None, 0) and r["multiplier"] is not None
        r["rel_error"] = (r["multiplier"] - r["reference"]) / abs(r["reference"]) if ok else math.nan
    return rows


def _read_rows(path: Path) -> list[dict]:
    """Rows of a runs.csv written by :func:`main`, with numbers and flags parsed."""
    def value(key, text):
        if key in ("verified", "certified"):
            return text == "True"
        if key in ("structure", "family", "strategy", "reference_source", "status"):
            return text
        return float(text) if text not in ("", "None") else None

    with path.open() as fh:
        rows = [{k: value(k, v) for k, v in r.items()} for r in csv.DictReader(fh)]
    for r in rows:
        r["rel_error"] = math.nan if r["rel_error"] is None else r["rel_error"]
    return rows


def _share(flags: list[bool]) -> str:
    return f"{sum(flags)}/{len(flags)}" if flags else "-"


def summary(rows: list[dict], strategies) -> list[dict]:
    table = []
    for label, _, _ in strategies:
        mine = [r for r in rows if r["strategy"] == label]
        cert = [r for r in mine if r["certified"]]
        below = [r for r in cert if r["reference"] < r["associative"] * (1 - 1e-6)]
        large = [r for r in mine if r["reference_source"] == "best verified"]
        errs = [r["rel_error"] for r in cert if not math.isnan(r["rel_error"])]
        errs_below = [r["rel_error"] for r in below if not math.isnan(r["rel_error"])]
        fric = [r["friction_admissibility"] for r in mine if r["verified"]]

        def within(rs, eps):
            return [r["verified"] and r["rel_error"] <= eps for r in rs]

        table.append({
            "strategy": label,
            "verified": _share([r["verified"] for r in cert]),
            "<=1%": _share(within(cert, 0.01)),
            "<=2%": _share(within(cert, 0.02)),
            "<=2% below assoc": _share(within(below, 0.02)),
            "large verified": _share([r["verified"] for r in large]),
            "large <=2% of best": _share(within(large, 0.02)),
            "median rel err": f"{round(statistics.median(errs), 6) + 0.0:.2%}" if errs else "-",
            "median rel err below assoc": f"{round(statistics.median(errs_below), 6) + 0.0:.2%}" if errs_below else "-",
            "max rel err": f"{round(max(errs), 6) + 0.0:.2%}" if errs else "-",
            "below cert": sum(1 for r in cert if r["verified"] and r["rel_error"] < -1e-7),
            "max fric adm": f"{max(fric):.1e}" if fric else "-",
            "median time s": f"{statistics.median(r['solve_time_s'] for r in mine):.3g}",
        })
    return table


def markdown(table: list[dict]) -> str:
    keys = list(table[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "|".join(" --- " if k == "strategy" else " ---: " for k in keys) + "|"]
    lines += ["| " + " | ".join(str(t[k]) for k in keys) + " |" for t in table]
    return "\n".join(lines)


def run_study(argv: list[str] | None, strategies_all: list, out: Path, default_time_limit: float,
              description: str) -> list[dict]:
    """The command line of a strategy study: run (or re-tabulate) ``strategies_all`` on the suite,
    print the summary table and write ``runs.csv`` and ``table.md`` into ``out``."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--only", default="", help="comma-separated substrings of strategy labels")
    parser.add_argument("--no-large", action="store_true", help="leave out the large walls")
    parser.add_argument("--time-limit", type=float, default=default_time_limit, help="seconds per run")
    parser.add_argument("--from-csv", action="store_true", help="re-tabulate the last runs.csv without running")
    parser.add_argument("--out", default=str(out), help="output folder (default: the study's own)")
    parser.add_argument("--first", type=int, default=None,
                        help="only the suite's first N structures (e.g. 2: two blocks, closed forms; a smoke run)")
    args = parser.parse_args(argv)
    out = Path(args.out)
    strategies = [s for s in strategies_all if not args.only or any(o in s[0] for o in args.only.split(","))]
    t0 = time.perf_counter()
    if args.from_csv:
        rows = _read_rows(out / "runs.csv")
        strategies = [s for s in strategies if any(r["strategy"] == s[0] for r in rows)]
    else:
        rows = run_all(strategies, suite(include_large=not args.no_large)[:args.first], args.time_limit)
    table = summary(rows, strategies)
    n_cert = len({r["structure"] for r in rows if r["certified"]})
    n_below = len({r["structure"] for r in rows if r["certified"] and r["reference"] < r["associative"] * (1 - 1e-6)})
    text = (f"{n_cert} structures with a certified minimum ({n_below} of them below the associative multiplier), "
            f"{len({r['structure'] for r in rows}) - n_cert} judged against the best verified value; "
            f"{time.perf_counter() - t0:.0f} s\n\n" + markdown(table))
    print(text)
    out.mkdir(parents=True, exist_ok=True)
    if not args.from_csv:
        with (out / "runs.csv").open("w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    (out / "table.md").write_text(text + "\n")
    print(f"wrote {out / 'runs.csv'} and {out / 'table.md'}")
    return table


def main(argv: list[str] | None = None) -> list[dict]:
    return run_study(argv, STRATEGIES, OUT, 120.0, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()

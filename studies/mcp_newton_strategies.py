"""mcp-newton strategies (starting points, continuation, fallback) on the heuristic suite.

Every strategy runs on every structure of ``studies/heuristic_suite.py`` and is
judged like the fixed-point strategies (same runner and table as
``studies/fixed_point_strategies.py``, imported from it): the share verified and
within 1 % / 2 % of the certified minimum (all certified structures, and those
whose minimum lies below the associative multiplier), the large walls against the
best verified value of the run, median and maximum relative error, runs below a
certificate (must be 0), friction admissibility and median solve time.

Strategies: ``start`` = ``associative`` (the former default: static LP (1), then the
continuation in the dilatancy ``tan(phi) -> tan(psi)``; also without continuation),
``fixed-point`` (the fixed point's default solution), ``dead-load`` and seeded
``random`` (one fixed-point step from those normal forces), ``nlp``; with and
without the associative ``fallback``.  The default ``fixed-point`` method is listed
as a reference row.

Use ``python studies/mcp_newton_strategies.py [--only LABEL,...] [--no-large] [--time-limit 60]``;
writes ``studies/output/mcp_newton_strategies/{runs.csv,table.md}``.  Certificates come
from the cache of ``heuristic_suite.py`` (run it first).
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from fixed_point_strategies import _read_rows, markdown, run_all, summary  # noqa: E402
from heuristic_suite import suite  # noqa: E402

OUT = Path(__file__).resolve().parent / "output" / "mcp_newton_strategies"

NEWTON = "mcp-newton"
STRATEGIES: list[tuple[str, str, dict]] = [
    ("newton associative, continuation (old default)", NEWTON, {"start": "associative"}),
    ("newton associative, no continuation", NEWTON, {"start": "associative", "continuation": False}),
    ("newton fixed-point", NEWTON, {"start": "fixed-point"}),
    ("newton fixed-point, no fallback", NEWTON, {"start": "fixed-point", "fallback": False}),
    ("newton dead-load", NEWTON, {"start": "dead-load"}),
    ("newton dead-load, no fallback", NEWTON, {"start": "dead-load", "fallback": False}),
    *[(f"newton random(seed={s})", NEWTON, {"start": "random", "seed": s}) for s in (0, 1, 2)],
    ("newton random(seed=0), no fallback", NEWTON, {"start": "random", "seed": 0, "fallback": False}),
    ("newton nlp", NEWTON, {"start": "nlp"}),
    ("fixed-point default (reference)", "fixed-point", {}),
]


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default="", help="comma-separated substrings of strategy labels")
    parser.add_argument("--no-large", action="store_true", help="leave out the large walls")
    parser.add_argument("--time-limit", type=float, default=60.0, help="seconds per run")
    parser.add_argument("--from-csv", action="store_true", help="re-tabulate the last runs.csv without running")
    args = parser.parse_args(argv)
    strategies = [s for s in STRATEGIES if not args.only or any(o in s[0] for o in args.only.split(","))]
    t0 = time.perf_counter()
    if args.from_csv:
        rows = _read_rows(OUT / "runs.csv")
        strategies = [s for s in strategies if any(r["strategy"] == s[0] for r in rows)]
    else:
        rows = run_all(strategies, suite(include_large=not args.no_large), args.time_limit)
    table = summary(rows, strategies)
    n_cert = len({r["structure"] for r in rows if r["certified"]})
    n_below = len({r["structure"] for r in rows if r["certified"] and r["reference"] < r["associative"] * (1 - 1e-6)})
    text = (f"{n_cert} structures with a certified minimum ({n_below} of them below the associative multiplier), "
            f"{len({r['structure'] for r in rows}) - n_cert} judged against the best verified value; "
            f"{time.perf_counter() - t0:.0f} s\n\n" + markdown(table))
    print(text)
    OUT.mkdir(parents=True, exist_ok=True)
    if not args.from_csv:
        with (OUT / "runs.csv").open("w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    (OUT / "table.md").write_text(text + "\n")
    print(f"wrote {OUT / 'runs.csv'} and {OUT / 'table.md'}")
    return table


if __name__ == "__main__":
    main()

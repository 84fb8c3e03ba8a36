r"""Every method on the built-in suite: the collapse multiplier (cf. the seed paper's Table 1) and the friction
admissibility error (cf. its Table 2).

The paper's Table 1 lists the collapse multiplier of four benchmark structures under associative friction and by
four non-associative methods; its Table 2 the relative friction admissibility error
``||(N_f^T x)_+|| / ||N_f^T x||``, of the order of 10 % for SLP and much smaller for its fixed point.  This script
makes the same two tables for the built-in suite of ``blockmpec compare`` and every registered method, with the
comparator :func:`blockmpec.bench.compare.compare`: each solve runs in its own worker process, is verified against
the residuals of the MCP (3), and is graded against a reference (closed form > certified minimum > best verified
value of another method).  Only the round arch has the paper's geometry (associative 0.16034); the others are our
structures, so compare the pattern, not the numbers.

The script exits with status 1 if the comparator flags an anomaly: a verified non-associative multiplier above the
associative one or below a certified minimum, or two verified associative multipliers that differ.

Run::

    python docs/gallery/table1_table2.py            # the whole suite, every method (a few minutes: milp stops at 60 s)
    python docs/gallery/table1_table2.py --small    # the four small structures (what CI runs, under a minute)

It writes the comparator's ``results.csv`` and the two tables as ``table1.csv`` and ``table2.csv`` into ``--out``
(default ``gallery-output/table1_table2``).  It uses only the public API.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import blockmpec as bm
from blockmpec.bench.compare import BENCHMARK_METHOD_OPTIONS, compare, pivot, text_table
from blockmpec.bench.suite import BENCHMARK_SUITE

#: the suite's structures on which every method finishes in about a second
SMALL = ("two-blocks", "round-arch", "arch-on-buttresses", "wall-4x2-stack")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true", help="the four small structures of the suite (the CI run)")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    parser.add_argument("--out", default="gallery-output/table1_table2", help="output folder (replaced)")
    args = parser.parse_args(argv)
    cases = {label: BENCHMARK_SUITE[label] for label in (SMALL if args.small else BENCHMARK_SUITE)}
    methods = [(name, name, BENCHMARK_METHOD_OPTIONS.get(name, {})) for name in bm.list_solvers()]
    out = Path(args.out)
    table = compare(cases, methods, n_jobs=args.jobs, out=out, overwrite=True, progress=False)
    pivot(table, "multiplier").to_csv(out / "table1.csv")
    pivot(table, "friction_admissibility").to_csv(out / "table2.csv")

    print(text_table(table, "multiplier", "{:.5f}", "Collapse multiplier lambda (cf. the paper's Table 1)",
                     reference=True))
    print()
    print(text_table(table, "friction_admissibility", "{:.1e}",
                     "Friction admissibility error ||(N_f^T x)+|| / ||N_f^T x|| (cf. the paper's Table 2)"))
    anomalies = table[table["anomaly"].astype(str) != ""]
    for _, row in anomalies.iterrows():
        print(f"anomaly: {row['case']} {row['method_label']}: {row['anomaly']}", file=sys.stderr)
    print(f"\n{len(table)} solves, {int(table['success'].sum())} verified successes, {len(anomalies)} anomalies; "
          f"wrote {out}")
    return 1 if len(anomalies) else 0


if __name__ == "__main__":
    sys.exit(main())

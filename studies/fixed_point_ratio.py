"""The fixed point's total time against one cold associative LP solve (issue 6's ratio).

For each running-bond wall size, in one process and one run:

* ``cold LP``: ``static-lp`` with each algorithm of ``--lp-algorithms`` (solve time only;
  set-up, i.e. Pyomo build + compile + load, is reported apart);
* ``fixed point``: ``fixed-point`` with its defaults (solve time, iterations, status), and
  the seconds its LPs took per kind: the associative start, the step LPs (5) and the
  tie-break LPs (``Result.extra["lp_time_s"]``);
* the ratios ``fixed point / cold LP`` for each LP algorithm.

Usage::

    python studies/fixed_point_ratio.py [--sizes 200,1000] [--lp-algorithms auto,ipm] [--time-limit 600]

Prints a markdown table and writes ``studies/output/fixed_point_ratio/ratio.csv``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import blockmpec as bm

sys.path.insert(0, str(Path(__file__).parent))
from benchmark_scaling import markdown, write_csv  # noqa: E402
from lp_timing import wall_for  # noqa: E402

OUT = Path(__file__).parent / "output" / "fixed_point_ratio"


def measure(n_blocks: int, lp_algorithms: list[str], time_limit: float) -> dict:
    ops = bm.assemble(wall_for(n_blocks))
    row: dict = {"blocks": ops.n_free_blocks}
    for algorithm in lp_algorithms:
        res = bm.solve(ops, "static-lp", algorithm=algorithm, time_limit=time_limit)
        row[f"lp_{algorithm}_s"] = res.solve_time_s
        row[f"lp_{algorithm}_setup_s"] = res.build_time_s
        row[f"lp_{algorithm}_status"] = res.status.value
    fp = bm.solve(ops, "fixed-point", time_limit=time_limit)
    row.update({
        "fp_s": fp.solve_time_s, "fp_setup_s": fp.build_time_s, "fp_status": fp.status.value,
        "fp_iterations": fp.iterations, "fp_multiplier": fp.multiplier,
        **{f"fp_{k}_s": v for k, v in fp.extra.get("lp_time_s", {}).items()},
    })
    for algorithm in lp_algorithms:
        lp = row[f"lp_{algorithm}_s"]
        row[f"ratio_vs_{algorithm}"] = fp.solve_time_s / lp if lp else math.nan
    return row


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="200,1000")
    parser.add_argument("--lp-algorithms", default="auto,ipm", help="static-lp algorithms to time cold")
    parser.add_argument("--time-limit", type=float, default=600.0)
    args = parser.parse_args(argv)
    algorithms = args.lp_algorithms.split(",")
    rows = [measure(int(n), algorithms, args.time_limit) for n in args.sizes.split(",")]
    keys = ["blocks", *[f"lp_{a}_s" for a in algorithms], "fp_s", "fp_iterations", "fp_status",
            "fp_associative_s", "fp_step_s", "fp_tie_break_s", *[f"ratio_vs_{a}" for a in algorithms]]
    print(markdown(rows, [(k, k, "{}" if k == "fp_status" else "{:.3g}") for k in keys]))
    OUT.mkdir(parents=True, exist_ok=True)
    write_csv(OUT / "ratio.csv", rows)
    print(f"wrote {OUT / 'ratio.csv'}")
    return rows


if __name__ == "__main__":
    main()

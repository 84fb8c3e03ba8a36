"""Timing of the associative pipeline on running-bond walls of growing size.

For each wall: structure generation (with interface detection), operator
assembly, Pyomo model build, compilation to matrices, HiGHS load, HiGHS solve,
and lam.  Usage::

    python studies/lp_timing.py [--sizes 100,1000,10000] [--algorithm auto]

Writes ``studies/output/lp_timing/lp_timing.csv``.
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

import blockmpec as bm
from formulations import compile_linear, static_lp
from solvers._highs import HighsLP

OUT = Path(__file__).parent / "output" / "lp_timing"


def wall_for(n_blocks: int) -> bm.Structure:
    """A running-bond wall with about ``n_blocks`` blocks, twice as long as high in blocks."""
    courses = max(1, round(math.sqrt(n_blocks / 2) * 1.0))
    per = max(1, round(n_blocks / courses))
    return bm.cases.wall(courses=courses, blocks_per_course=per)


def time_one(n_blocks: int, algorithm: str) -> dict:
    t0 = time.perf_counter()
    s = wall_for(n_blocks)
    t1 = time.perf_counter()
    ops = bm.assemble(s)
    t2 = time.perf_counter()
    problem = static_lp(ops)
    t3 = time.perf_counter()
    lp = compile_linear(problem)
    t4 = time.perf_counter()
    highs = HighsLP(lp, algorithm)
    t5 = time.perf_counter()
    out = highs.solve()
    t6 = time.perf_counter()
    lam = float(lp.values("lam", out.v)[0])
    return {
        "blocks": s.n_free, "interfaces": len(s.interfaces), "rows": lp.A.shape[0], "columns": lp.A.shape[1],
        "generate_s": t1 - t0, "assemble_s": t2 - t1, "pyomo_build_s": t3 - t2, "compile_s": t4 - t3,
        "highs_load_s": t5 - t4, "solve_s": t6 - t5, "algorithm": algorithm, "status": out.status.value,
        "multiplier": lam, "lp_iterations": out.iterations,
    }


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="100,1000,10000")
    parser.add_argument("--algorithm", default="auto")
    args = parser.parse_args(argv)
    rows = [time_one(int(n), args.algorithm) for n in args.sizes.split(",")]
    keys = ["blocks", "generate_s", "assemble_s", "pyomo_build_s", "compile_s", "highs_load_s", "solve_s", "status", "multiplier"]
    print(" ".join(f"{k:>13s}" for k in keys))
    for r in rows:
        print(" ".join(f"{r[k]:>13.4g}" if isinstance(r[k], float) else f"{r[k]!s:>13s}" for k in keys))
    OUT.mkdir(parents=True, exist_ok=True)
    with (OUT / "lp_timing.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {OUT / 'lp_timing.csv'}")
    return rows


if __name__ == "__main__":
    main()

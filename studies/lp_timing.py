"""Timing of the associative pipeline on running-bond walls of growing size.

For each wall and LP algorithm: structure generation (with interface detection),
operator assembly, Pyomo model build, compilation to matrices, engine load, cold
solve, lam, and the ratio of model construction (build + compile) to the solve.
Algorithms are those of ``static-lp`` (``blockmpec.solvers.engines.lp_engine.ALGORITHMS``):
HiGHS's ``dual-simplex``, ``primal-simplex``, ``ipm`` (with crossover), the
``block-ipm``, or ``auto``.  Usage::

    python studies/lp_timing.py [--sizes 100,1000,10000] [--algorithms auto] [--time-limit 600]

Writes ``studies/output/lp_timing/lp_timing.csv``.
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

import blockmpec as bm
from blockmpec.formulations import compile_linear, static_lp
from blockmpec.solvers.engines.lp_engine import cold_lp_engine

OUT = Path(__file__).parent / "output" / "lp_timing"


def wall_for(n_blocks: int) -> bm.Structure:
    """A running-bond wall with about ``n_blocks`` blocks, twice as long as high in blocks."""
    courses = max(1, round(math.sqrt(n_blocks / 2) * 1.0))
    per = max(1, round(n_blocks / courses))
    return bm.cases.wall(courses=courses, blocks_per_course=per)


def time_one(n_blocks: int, algorithm: str, time_limit: float = float("inf")) -> dict:
    t0 = time.perf_counter()
    s = wall_for(n_blocks)
    t1 = time.perf_counter()
    ops = bm.assemble(s)
    t2 = time.perf_counter()
    problem = static_lp(ops)
    t3 = time.perf_counter()
    lp = compile_linear(problem)
    t4 = time.perf_counter()
    engine = cold_lp_engine(lp, algorithm, time_limit, ops=ops)  # as static-lp runs it: in load units
    t5 = time.perf_counter()
    out = engine.solve()
    t6 = time.perf_counter()
    lam = float(lp.values("lam", out.v)[0]) if out.status.is_success else math.nan
    return {
        "blocks": s.n_free, "interfaces": len(s.interfaces), "rows": lp.A.shape[0], "columns": lp.A.shape[1],
        "generate_s": t1 - t0, "assemble_s": t2 - t1, "pyomo_build_s": t3 - t2, "compile_s": t4 - t3,
        "load_s": t5 - t4, "solve_s": t6 - t5, "build_over_solve": (t4 - t2) / (t6 - t5),
        "algorithm": algorithm, "engine": type(engine).__name__, "status": out.status.value,
        "multiplier": lam, "lp_iterations": out.iterations,
    }


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="100,1000,10000")
    parser.add_argument("--algorithms", default="auto", help="comma-separated static-lp algorithms")
    parser.add_argument("--time-limit", type=float, default=float("inf"), help="seconds per solve")
    args = parser.parse_args(argv)
    rows = [time_one(int(n), a, args.time_limit) for n in args.sizes.split(",") for a in args.algorithms.split(",")]
    keys = ["blocks", "algorithm", "generate_s", "assemble_s", "pyomo_build_s", "compile_s", "load_s", "solve_s",
            "build_over_solve", "status", "multiplier"]
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

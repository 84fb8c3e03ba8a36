"""Cost growth with structure size: walls from 10 to 100,000 blocks.

For each size, in a fresh subprocess (so that peak memory is its own): structure
generation (with interface detection), operator assembly, and for each method
its set-up time (Pyomo build + compile + load), solve time, iterations, status
and lam; peak resident memory of the subprocess.  A log-log fit of time against
blocks gives the growth exponent.  Usage::

    python studies/benchmark_scaling.py [--sizes 10,100,1000,10000] [--methods static-lp,fixed-point]
                                        [--time-limit 600]

Writes ``studies/output/benchmark_scaling/scaling.csv``.  Figures quoted in the
README's performance section come from this script; quote ratios from one run.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

OUT = Path(__file__).parent / "output" / "benchmark_scaling"

CHILD = r"""
import json, resource, sys, time
import blockmpec as bm
n, methods, limit = int(sys.argv[1]), sys.argv[2].split(","), float(sys.argv[3])
courses = max(1, round((n / 2) ** 0.5)); per = max(1, round(n / courses))
t0 = time.perf_counter(); s = bm.cases.wall(courses=courses, blocks_per_course=per); t1 = time.perf_counter()
ops = bm.assemble(s); t2 = time.perf_counter()
rows = []
for m in methods:
    opts = {"time_limit": limit} if "time_limit" in [f[0] for f in bm.solver.option_fields(bm.get_solver(m))] else {}
    r = bm.solve(ops, m, **opts)
    rows.append(dict(blocks=s.n_free, method=m, generate_s=t1 - t0, assemble_s=t2 - t1, setup_s=r.build_time_s,
                     solve_s=r.solve_time_s, iterations=r.iterations, status=r.status.value, multiplier=r.multiplier,
                     max_residual=r.max_residual, lp_solves=r.extra.get("lp_solves")))
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
for row in rows:
    row["peak_memory_mb"] = peak
print(json.dumps(rows))
"""


def fit_exponent(blocks: list[float], times: list[float]) -> float:
    """Slope of log(time) against log(blocks) (least squares)."""
    x, y = np.log(blocks), np.log(np.maximum(times, 1e-9))
    return float(np.polyfit(x, y, 1)[0]) if len(x) > 1 else math.nan


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="10,100,1000,10000")
    parser.add_argument("--methods", default="static-lp,fixed-point")
    parser.add_argument("--time-limit", type=float, default=600.0)
    args = parser.parse_args(argv)
    rows: list[dict] = []
    for n in (int(v) for v in args.sizes.split(",")):
        p = subprocess.run([sys.executable, "-c", CHILD, str(n), args.methods, str(args.time_limit)],
                           capture_output=True, text=True)
        if p.returncode != 0:
            print(f"size {n}: failed: {p.stderr.strip().splitlines()[-1] if p.stderr else p.returncode}")
            continue
        rows.extend(json.loads(p.stdout.strip().splitlines()[-1]))
        for r in rows[-len(args.methods.split(",")):]:
            print(f"{r['blocks']:>7d} {r['method']:>14s} generate {r['generate_s']:8.3f}s assemble {r['assemble_s']:7.3f}s "
                  f"setup {r['setup_s']:8.3f}s solve {r['solve_s']:8.3f}s it {r['iterations']:>4} "
                  f"{r['status']:>10s} lam {r['multiplier'] if r['multiplier'] is None else round(r['multiplier'], 6)} "
                  f"peak {r['peak_memory_mb']:.0f} MB", flush=True)
    if not rows:
        return rows
    print("\nlog-log growth exponents (time ~ blocks^k):")
    for m in args.methods.split(","):
        sub = [r for r in rows if r["method"] == m and r["status"] not in ("error", "skipped")]
        if len(sub) > 1:
            b = [r["blocks"] for r in sub]
            print(f"  {m:>14s}: setup k = {fit_exponent(b, [r['setup_s'] for r in sub]):.2f}, "
                  f"solve k = {fit_exponent(b, [r['solve_s'] for r in sub]):.2f}")
    b = sorted({r["blocks"] for r in rows})
    gen = [next(r["generate_s"] for r in rows if r["blocks"] == v) for v in b]
    asm = [next(r["assemble_s"] for r in rows if r["blocks"] == v) for v in b]
    print(f"  {'structure':>14s}: generate k = {fit_exponent(b, gen):.2f}, assemble k = {fit_exponent(b, asm):.2f}")
    OUT.mkdir(parents=True, exist_ok=True)
    with (OUT / "scaling.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {OUT / 'scaling.csv'}")
    return rows


if __name__ == "__main__":
    main()

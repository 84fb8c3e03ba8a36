"""Time solves of running-bond walls through the public API only, so that two installs can be compared.

Issue 40 asked that the restructuring leave behaviour and numbers unchanged: the 1,010-, 10,050- and
100,014-block static LPs within 5 % of their time before, with the same ``lam``, and the fixed point on 1,010
blocks at most 1.5x one LP.  This script uses nothing but ``bm.cases.wall`` and ``bm.solve`` (and ``Result``'s
fields), which exist unchanged before and after, so the same file runs under both installs: run it from each
environment in turn, interleaved, in one session, and compare the rows.  Each row: the wall, the method, the
status, ``lam`` (full precision, to compare bit for bit), the solve time (set-up excluded), the build time,
the iterations, the CPU time of the whole ``bm.solve`` call in this process (and the Cholesky worker's, where
the block IPM ran one), the peak resident memory of this process, and whether the verifier agreed.

Usage (one environment per install; ``--label`` names it in the rows)::

    python studies/lab/public_api_timing.py --label after --walls 20x50,100x100 --methods static-lp
    python studies/lab/public_api_timing.py --label after --walls 20x50 --methods fixed-point
    python studies/lab/public_api_timing.py --label after --walls 316x316 --methods static-lp

Appends JSON lines to ``studies/output/public_api_timing.jsonl`` (``--out``) and prints them.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import blockmpec as bm

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from _tables import peak_memory_mb  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "public_api_timing.jsonl"


def measure(label: str, courses: int, per_course: int, method: str) -> dict:
    """One solve of the ``courses x per_course`` running-bond wall by ``method``, as a row."""
    wall = bm.cases.wall(courses, per_course)
    t0, p0 = time.perf_counter(), time.process_time()
    res = bm.solve(wall, method)
    return {
        "label": label, "wall": f"{courses}x{per_course}", "blocks": int(wall.n_free), "method": method,
        "status": res.status.value, "lam": res.multiplier, "solve_s": res.solve_time_s, "build_s": res.build_time_s,
        "iterations": res.iterations, "cpu_s": time.process_time() - p0, "wall_s": time.perf_counter() - t0,
        "worker_cpu_s": res.extra.get("factor_worker_cpu_s"),
        "peak_mb": peak_memory_mb(), "verified": bool(res.verified),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--label", required=True, help="names the install in the rows (e.g. before, after)")
    parser.add_argument("--walls", default="20x50", help="comma-separated CxB running-bond walls (default 20x50)")
    parser.add_argument("--methods", default="static-lp", help="comma-separated methods (default static-lp)")
    parser.add_argument("--out", type=Path, default=OUT, help=f"JSON-lines file to append to (default {OUT})")
    args = parser.parse_args(argv)
    try:
        walls = [tuple(int(v) for v in w.split("x")) for w in args.walls.split(",")]
    except ValueError:
        parser.error(f"--walls {args.walls}: expected CxB,CxB,... (e.g. 20x50)")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    for courses, per_course in walls:
        for method in args.methods.split(","):
            row = measure(args.label, courses, per_course, method)
            print(json.dumps(row), flush=True)
            with args.out.open("a") as f:
                f.write(json.dumps(row) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""The fixed point's total time against one cold associative LP solve (issue 6's ratio; issue 14's target).

For each running-bond wall size, in one run, each solve in a fresh process of its own (so that its peak
resident memory, ``*_peak_memory_mb``, is its own: imports, assembly, model and solve):

* ``cold LP``: ``static-lp`` with each algorithm of ``--lp-algorithms`` (solve time only;
  set-up, i.e. Pyomo build + compile + load, is reported apart; ``--lp-algorithms block-ipm``
  is the cold LP of issue 14's target);
* ``fixed point``: ``fixed-point`` with each option set of ``--fixed-point`` (default: its
  defaults, and the old default ``start=associative, tie_break=closest``): solve time,
  iterations, status, lam, and the seconds its LPs took per kind (the start LP, the step
  LPs (5), the tie-break LPs; ``Result.extra["lp_time_s"]``);
* the ratios ``fixed point / cold LP`` for each LP algorithm, in wall-clock seconds of the
  solve (``ratio_vs_*``) and in CPU seconds of the solve (``cpu_ratio_vs_*``: the method's
  ``run`` under ``time.process_time``, set-up and verification excluded; the machine is
  shared, so CPU time is the fairer clock).

Example (issue 14: the interior engine against one cold block-IPM LP)::

    python studies/lab/fixed_point_ratio.py --walls 20x50,100x100 --lp-algorithms block-ipm \
        --fixed-point "engine=interior;engine=interior,interior_weight=0"

Usage::

    python studies/lab/fixed_point_ratio.py [--sizes 200,1000 | --walls 20x50,100x100] [--lp-algorithms auto,ipm]
        [--fixed-point "default;start=associative,tie_break=closest"] [--time-limit 600]

Prints a markdown table and writes ``studies/output/fixed_point_ratio/ratio_<walls>.csv``.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import sys
from pathlib import Path

import blockmpec as bm
from blockmpec.cli import parse_pairs

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _methods import configured  # noqa: E402
from _tables import markdown, peak_memory_mb, write_csv  # noqa: E402
from _walls import wall_or_size  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "fixed_point_ratio"


def timed_solve(ops, method: str, **values):
    """``bm.solve`` (``values``: options and engine settings, :func:`_methods.configured`) plus the CPU seconds of the
    method's ``run`` alone (set-up and verification excluded), with those of the static LP's factorisation worker
    process when it had one."""
    import time

    solver = configured(method, **values)
    original = solver.run
    clock: dict = {}

    def run(deadline):
        t0 = time.process_time()
        try:
            return original(deadline)
        finally:
            clock["cpu_s"] = time.process_time() - t0

    solver.run = run  # this instance's run, timed
    res = bm.run_solver(solver, ops)
    # plus a static LP's factorisation worker process, if it had one (its CPU is not in this process's clock)
    return res, clock.get("cpu_s", math.nan) + res.extra.get("factor_worker_cpu_s", 0.0)


def parse_options(text: str) -> dict:
    """``"a=1,b=x"`` -> ``{"a": 1, "b": "x"}`` (the CLI's ``KEY=VALUE`` reader: JSON values, else strings);
    ``"default"`` -> ``{}``."""
    return parse_pairs([item for item in text.split(",") if item and item != "default"], "--fixed-point")


def solve_in_child(wall: str, method: str, options: dict, time_limit: float) -> dict:
    """One solve of ``wall`` (run in a fresh process): what the tables need, and the process's peak memory."""
    ops = bm.assemble(wall_or_size(wall))
    res, cpu = timed_solve(ops, method, time_limit=time_limit, **options)
    return {"blocks": ops.n_free_blocks, "s": res.solve_time_s, "cpu_s": cpu, "setup_s": res.build_time_s,
            "status": res.status.value, "verified": bool(res.success), "multiplier": res.multiplier,
            "iterations": res.iterations, "engine": res.extra.get("engine"),
            "lp_time_s": dict(res.extra.get("lp_time_s", {})), "peak_memory_mb": peak_memory_mb()}


def _fresh(*args) -> dict:
    context = multiprocessing.get_context("spawn")
    with context.Pool(1, maxtasksperchild=1) as pool:
        return pool.apply(solve_in_child, args)


def measure(wall: str, lp_algorithms: list[str], fixed_points: list[str], time_limit: float,
            lp_factor_processes: str | int = "auto") -> list[dict]:
    base: dict = {"wall": wall}
    for algorithm in lp_algorithms:
        lp = _fresh(wall, "static-lp", {"algorithm": algorithm, "factor_processes": lp_factor_processes}, time_limit)
        base["blocks"] = lp["blocks"]
        base[f"lp_{algorithm}_s"] = lp["s"]
        base[f"lp_{algorithm}_cpu_s"] = lp["cpu_s"]
        base[f"lp_{algorithm}_setup_s"] = lp["setup_s"]
        base[f"lp_{algorithm}_status"] = lp["status"]
        base[f"lp_{algorithm}_multiplier"] = lp["multiplier"]
        base[f"lp_{algorithm}_peak_memory_mb"] = lp["peak_memory_mb"]
        print(f"{wall}: static-lp {algorithm} {lp['status']} {lp['s']:.3g} s (CPU {lp['cpu_s']:.3g} s), "
              f"peak {lp['peak_memory_mb']:.0f} MB", flush=True)
    rows = []
    for text in fixed_points:
        fp = _fresh(wall, "fixed-point", parse_options(text), time_limit)
        row = {**base, "blocks": fp["blocks"], "fixed_point": text, "fp_s": fp["s"], "fp_cpu_s": fp["cpu_s"],
               "fp_setup_s": fp["setup_s"], "fp_status": fp["status"], "fp_verified": fp["verified"],
               "fp_engine": fp["engine"], "fp_iterations": fp["iterations"], "fp_multiplier": fp["multiplier"],
               "fp_peak_memory_mb": fp["peak_memory_mb"], **{f"fp_{k}_s": v for k, v in fp["lp_time_s"].items()}}
        for algorithm in lp_algorithms:
            lp = base[f"lp_{algorithm}_s"]
            row[f"ratio_vs_{algorithm}"] = fp["s"] / lp if lp else math.nan
            lp_cpu = base[f"lp_{algorithm}_cpu_s"]
            row[f"cpu_ratio_vs_{algorithm}"] = fp["cpu_s"] / lp_cpu if lp_cpu else math.nan
        print(f"{wall}: fixed-point {text}: {fp['status']} (verified {fp['verified']}) lam={fp['multiplier']} "
              f"{fp['s']:.3g} s (CPU {fp['cpu_s']:.3g} s), peak {fp['peak_memory_mb']:.0f} MB", flush=True)
        rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="200,1000", help="wall sizes in blocks (_walls.wall_for)")
    parser.add_argument("--walls", default="", help="walls as CxB (courses x blocks per course); overrides --sizes")
    parser.add_argument("--fixed-point", default="default;start=associative,tie_break=closest",
                        help="';'-separated fixed-point option sets (k=v,... of options and engine settings; "
                             "'default' = its defaults)")
    parser.add_argument("--lp-algorithms", default="auto,ipm", help="static-lp algorithms to time cold")
    parser.add_argument("--lp-factor-processes", default="auto", choices=("auto", "1", "2"),
                        help="static-lp's factor_processes for the cold LPs (1: the tables measured before two "
                             "processes became the default)")
    parser.add_argument("--time-limit", type=float, default=600.0)
    args = parser.parse_args(argv)
    algorithms = args.lp_algorithms.split(",")
    walls = args.walls.split(",") if args.walls else args.sizes.split(",")
    processes = args.lp_factor_processes if args.lp_factor_processes == "auto" else int(args.lp_factor_processes)
    rows = [r for w in walls for r in measure(w, algorithms, args.fixed_point.split(";"), args.time_limit, processes)]
    keys = ["blocks", *[f"lp_{a}_cpu_s" for a in algorithms], *[f"lp_{a}_peak_memory_mb" for a in algorithms],
            "fixed_point", "fp_engine", "fp_cpu_s", "fp_iterations", "fp_status", "fp_verified", "fp_multiplier",
            "fp_peak_memory_mb", *[f"ratio_vs_{a}" for a in algorithms],
            *[f"cpu_ratio_vs_{a}" for a in algorithms]]
    text_keys = ("fp_status", "fixed_point", "fp_engine", "fp_verified")
    print(markdown(rows, [(k, k, "{}" if k in text_keys else "{:.5g}" if k == "fp_multiplier" else "{:.3g}")
                          for k in keys]))
    path = write_csv(OUT / f"ratio_{'_'.join(walls)}.csv", rows)
    print(f"wrote {path}")
    return rows


if __name__ == "__main__":
    main()

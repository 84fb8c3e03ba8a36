"""How large a running-bond wall ``nlp`` solves within a time limit, per option set.

For each option set (``--configs``), walls of growing size (``--walls``, ``courses x
blocks_per_course``, running bond) are solved with ``nlp`` under ``time_limit``; a
set's sweep stops at its first wall without a verified answer.  Per run: status,
verified, lam (and the associative lam it started from), wall-clock and process CPU
seconds (the CPU column is the fair one on a shared machine: Ipopt and MUMPS are
single-threaded here, so CPU seconds are what the run would take alone), Ipopt
iterations and the iterations per eps stage.  With ``--fixed-point`` each wall is also solved
once by the registered ``fixed-point`` method (its lam, to compare with, and its CPU seconds,
the cost of ``start="fixed-point"``).  ``--keep-going`` runs every wall of a set even after a
failure.  The default sets are ``ipopt`` (the Ipopt stages from the associative start: ``nlp``'s route below
100 free blocks), ``factor-0.01``, ``penalty-fp`` (``start="fixed-point", complementarity="penalty"``),
``pieces-whole`` (the fixed point's solution straight to piece LPs solved as one HiGHS LP each, the piece route
before the split) and ``pieces`` (``route="pieces"``: the split piece LPs, ``nlp``'s route from 100 free blocks on).  ``time_limit`` is wall-clock (Ipopt's
``max_wall_time``, as the runner times a solve), so on a loaded machine a run gets less CPU
than its limit.  Usage::

    python studies/lab/nlp_scaling.py [--walls 5x4,10x5,10x10,20x10] [--time-limit 60] [--fixed-point]
                                  [--configs "default={};factor-0.01={'eps_factor': 0.01}"] [--tag T]

Writes ``studies/output/nlp/nlp_scaling[_TAG].csv`` and prints a table, then a markdown table
(one row per wall: each set's CPU seconds, status and lam, the fixed point's lam).
"""

from __future__ import annotations

import argparse
import ast
import sys
import time
from pathlib import Path

import blockmpec as bm
from blockmpec import facts

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _methods import solve  # noqa: E402
from _tables import csv_rows  # noqa: E402
from _tables import fmt as _fmt  # noqa: E402
from _walls import wall_shapes  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "nlp"
COLUMNS = ["config", "wall", "blocks", "status", "verified", "multiplier", "associative", "wall_s", "cpu_s",
           "solve_s", "setup_s", "ipopt_iterations", "stages", "route", "certified", "start_s", "lp_s", "static_lp_s",
           "kinematic_lp_s", "message"]
DEFAULT_CONFIGS = ("ipopt={'route': 'ipopt'};factor-0.01={'route': 'ipopt', 'eps_factor': 0.01};"
                   "penalty-fp={'route': 'ipopt', 'start': 'fixed-point', 'complementarity': 'penalty'};"
                   "pieces-whole={'route': 'pieces', 'piece_lps': 'whole'};pieces={'route': 'pieces'}")


def parse_configs(text: str) -> dict[str, dict]:
    """``"name={options};name2={...}"`` -> ``{name: options}`` (a Python dict literal of options and engine settings,
    sent where each belongs by :func:`_methods.solve`)."""
    out = {}
    for part in filter(None, (p.strip() for p in text.split(";"))):
        name, _, literal = part.partition("=")
        options = ast.literal_eval(literal.strip() or "{}")
        if not isinstance(options, dict):
            raise SystemExit(f"--configs: {name!r} must map to a dict of nlp options and settings; got {literal!r}")
        out[name.strip()] = options
    return out


def run_wall(config: str, courses: int, per_course: int, time_limit: float, options: dict,
             method: str = "nlp") -> dict:
    """Solve one running-bond wall with ``method`` (``nlp``) and ``options``; one table row."""
    structure = bm.cases.wall(courses=courses, blocks_per_course=per_course)
    c0, t0 = time.process_time(), time.perf_counter()
    res = solve(structure, method, time_limit=time_limit, **options)
    wall_s, cpu_s = time.perf_counter() - t0, time.process_time() - c0
    stages = " ".join(f"{rec['stage']}:{rec.get('ipopt_iterations', 0)}" for rec in res.trace if "stage" in rec)
    return {"config": config, "wall": f"{courses}x{per_course}", "blocks": structure.n_free,
            "status": res.status.value, "verified": res.success, "multiplier": res.multiplier,
            "associative": res.extra.get(facts.ASSOCIATIVE_MULTIPLIER), "wall_s": wall_s, "cpu_s": cpu_s,
            "solve_s": res.solve_time_s, "setup_s": res.build_time_s, "ipopt_iterations": res.iterations, "stages": stages,
            "route": res.extra.get("route"), "certified": res.extra.get("piece_certified"),
            "start_s": res.extra.get("start_time_s"), "lp_s": res.extra.get(facts.LP_TIME_S),
            "static_lp_s": res.extra.get("static_lp_time_s"), "kinematic_lp_s": res.extra.get("kinematic_lp_time_s"),
            "message": res.message[:100]}


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", default="5x4,10x5,10x10,20x10,20x25")
    ap.add_argument("--time-limit", type=float, default=60.0)
    ap.add_argument("--configs", default=DEFAULT_CONFIGS)
    ap.add_argument("--tag", default="")
    ap.add_argument("--fixed-point", action="store_true", help="also solve each wall once with fixed-point")
    ap.add_argument("--keep-going", action="store_true", help="do not stop a set at its first unverified wall")
    args = ap.parse_args(argv)
    walls = wall_shapes(args.walls)
    path = OUT / f"nlp_scaling{'_' + args.tag if args.tag else ''}.csv"
    rows = []
    with csv_rows(path, COLUMNS) as append:
        runs = [(config, options, "nlp") for config, options in parse_configs(args.configs).items()]
        if args.fixed_point:
            runs.insert(0, ("fixed-point", {}, "fixed-point"))
        for config, options, method in runs:
            for courses, per_course in walls:
                row = run_wall(config, courses, per_course, args.time_limit, options, method)
                rows.append(row)
                append(row)
                print("  ".join(f"{k}={_fmt(row[k])}" for k in COLUMNS[:11]), flush=True)
                if not row["verified"] and not args.keep_going:
                    break
    print("\n| config | largest verified wall (blocks) | its wall s | its CPU s |\n|---|---|---|---|")
    for config in parse_configs(args.configs):
        ok = [r for r in rows if r["config"] == config and r["verified"]]
        best = max(ok, key=lambda r: r["blocks"]) if ok else None
        print(f"| {config} | {best['wall'] + ' (' + str(best['blocks']) + ')' if best else 'none'} | "
              f"{_fmt(best['wall_s']) if best else '-'} | {_fmt(best['cpu_s']) if best else '-'} |")
    print_markdown(rows, [r[0] for r in runs])
    print(f"\nwritten: {path}")
    return rows


def print_markdown(rows: list[dict], configs: list[str]) -> None:
    """One row per wall: per set, ``CPU s, status (* = not verified), lam``."""
    walls = sorted({(r["blocks"], r["wall"]) for r in rows})
    print("\n| wall (blocks) | " + " | ".join(configs) + " |")
    print("|---|" + "---|" * len(configs))
    for blocks, wall in walls:
        cells = []
        for config in configs:
            r = next((r for r in rows if r["config"] == config and r["wall"] == wall), None)
            if r is None:
                cells.append("–")
                continue
            lam = "–" if r["multiplier"] is None else f"{r['multiplier']:.5f}"
            mark = "" if r["verified"] else "*"
            cells.append(f"{r['cpu_s']:.1f} s, {r['status']}{mark}, λ {lam}")
        print(f"| {wall} ({blocks}) | " + " | ".join(cells) + " |")
    print("(CPU seconds of the whole solve, set-up included; * = not verified)")


if __name__ == "__main__":
    main()

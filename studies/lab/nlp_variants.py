"""``nlp`` option sets against each other and against certified minima of (4): lam and CPU time.

Cases: the README's suite (``blockmpec compare``'s ``BENCHMARK_SUITE``) and every structure
of ``studies/lab/heuristic_suite.py`` whose minimum is known without computing anything here
(two-block closed forms; ``milp`` certificates read from the cache
``studies/output/heuristic_suite/certificates.json``, never recomputed; structures without
a cached certificate are left out).  Each option set (``--configs``, as in
``nlp_scaling.py``) and the registered ``fixed-point`` method solve every case once; per
run: status, verified, lam, process CPU seconds (set-up included).  Prints the README-suite
lam table (one column per set, ``*`` = not verified), then per set: verified, within 1e-6
relative and within 1 % of the certified minimum, never below it, median CPU seconds.
Usage::

    python studies/lab/nlp_variants.py [--configs "ipopt={'route': 'ipopt'};pieces={'route': 'pieces'}"] [--time-limit 60] [--tag T]

Writes ``studies/output/nlp/nlp_variants[_TAG].csv``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import blockmpec as bm
from blockmpec.bench.suite import BENCHMARK_SUITE

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
import _methods  # noqa: E402
import heuristic_suite  # noqa: E402
from _tables import csv_rows  # noqa: E402
from nlp_scaling import DEFAULT_CONFIGS, OUT, parse_configs  # noqa: E402

COLUMNS = ["config", "case", "suite", "reference", "status", "verified", "multiplier", "cpu_s", "solve_s"]


def cases() -> list[tuple[str, str, bm.Structure, float | None]]:
    """``(label, suite, structure, certified minimum or None)``: README suite, then the certified suite."""
    out = []
    for label, (name, params) in BENCHMARK_SUITE.items():
        out.append((label, "readme", bm.cases.build_case(name, **params), None))
    for entry in heuristic_suite.suite(include_large=False):
        ref = heuristic_suite.certificate(entry, compute=False)
        if ref.get("certified") and ref.get("value") is not None:
            out.append((entry.label, "certified", entry.build(), float(ref["value"])))
    return out


def solve(structure: bm.Structure, method: str, options: dict, time_limit: float) -> tuple[bm.Result, float]:
    c0 = time.process_time()
    res = _methods.solve(structure, method, time_limit=time_limit, **options)
    return res, time.process_time() - c0


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--configs", default=DEFAULT_CONFIGS)
    ap.add_argument("--time-limit", type=float, default=60.0)
    ap.add_argument("--tag", default="")
    args = ap.parse_args(argv)
    runs = [("fixed-point", "fixed-point", {})] + [(c, "nlp", o) for c, o in parse_configs(args.configs).items()]
    path = OUT / f"nlp_variants{'_' + args.tag if args.tag else ''}.csv"
    rows = []
    with csv_rows(path, COLUMNS) as append:
        for label, suite, structure, reference in cases():
            for config, method, options in runs:
                res, cpu = solve(structure, method, options, args.time_limit)
                row = {"config": config, "case": label, "suite": suite, "reference": reference,
                       "status": res.status.value, "verified": res.success, "multiplier": res.multiplier,
                       "cpu_s": cpu, "solve_s": res.solve_time_s}
                rows.append(row)
                append(row)
            print(label, " ".join(f"{r['config']}={r['multiplier']}" for r in rows if r["case"] == label), flush=True)
    configs = [r[0] for r in runs]
    print("\n| case | " + " | ".join(configs) + " |\n|---|" + "---|" * len(configs))
    for label in BENCHMARK_SUITE:
        cells = []
        for config in configs:
            r = next(r for r in rows if r["case"] == label and r["config"] == config)
            lam = "–" if r["multiplier"] is None else f"{r['multiplier']:.5f}"
            cells.append(f"{lam}{'' if r['verified'] else '*'} ({r['cpu_s']:.2f} s)")
        print(f"| {label} | " + " | ".join(cells) + " |")
    certified = [r for r in rows if r["suite"] == "certified"]
    n = len({r["case"] for r in certified})
    print("\n| set | verified | = minimum (1e-6 rel.) | within 1 % | below a certificate | median CPU s |"
          "\n|---|---:|---:|---:|---:|---:|")
    for config in configs:
        mine = [r for r in certified if r["config"] == config]
        ok = [r for r in mine if r["verified"]]

        def err(r):
            return (r["multiplier"] - r["reference"]) / max(abs(r["reference"]), 1e-12)

        exact = sum(abs(err(r)) <= 1e-6 for r in ok)
        within = sum(abs(err(r)) <= 1e-2 for r in ok)
        below = sum(err(r) < -1e-6 for r in ok)
        print(f"| {config} | {len(ok)}/{n} | {exact}/{n} | {within}/{n} | {below} | "
              f"{statistics.median(r['cpu_s'] for r in mine):.3f} |")
    print(f"\nwritten: {path}")
    return rows


if __name__ == "__main__":
    main()

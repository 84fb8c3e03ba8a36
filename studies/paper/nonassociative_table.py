"""Associative vs non-associative collapse multipliers on the built-in cases.

For each case: ``lam`` of the associative static LP (1), of the fixed-point method
(its defaults, the former default ``start="associative", tie_break="closest"`` and the
plain ``tie_break="none"``) and of the SLP heuristic
(published ``alpha = 0.01``, ``beta = 0.6``), with iterations, the friction
admissibility error ``||(N_f^T x)_+|| / ||N_f^T x||``, the worst residual of (3),
the status and the solve time.  Prints a table and writes
``studies/output/nonassociative/table.csv``.

Run: ``python studies/paper/nonassociative_table.py [--smoke]`` (``--smoke``: the two-block case only).
"""

from __future__ import annotations

import csv
from pathlib import Path

import blockmpec as bm

CASES = [
    ("two-blocks", {}),
    ("round-arch", {}),
    ("arch-on-buttresses", {}),
    ("wall", {}),
    ("wall", {"courses": 10, "blocks_per_course": 5}),
    ("wall", {"courses": 10, "blocks_per_course": 20}),
]

RUNS = [
    ("static-lp", "static-lp", {}),
    ("fixed-point", "fixed-point", {}),
    ("fixed-point/assoc+closest", "fixed-point", {"start": "associative", "tie_break": "closest"}),
    ("fixed-point/none", "fixed-point", {"start": "associative", "tie_break": "none"}),
    ("slp", "slp", {}),
]

OUTPUT = Path(__file__).resolve().parents[1] / "output" / "nonassociative"


def case_label(name: str, params: dict) -> str:
    if not params:
        return name
    return f"{name}({params['courses']}x{params['blocks_per_course']})"


def main(argv: list[str] | None = None) -> list[dict]:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="the smallest run: the two-block case only (CI)")
    args = parser.parse_args(argv)
    rows = []
    for name, params in CASES[:1] if args.smoke else CASES:
        structure = bm.build_case(name, **params)
        ops = bm.assemble(structure)
        for label, method, options in RUNS:
            res = bm.solve(ops, method, **options)
            rows.append({
                "case": case_label(name, params),
                "run": label,
                "status": res.status.value,
                "multiplier": res.multiplier,
                "iterations": res.iterations,
                "lp_solves": res.extra.get("lp_solves", 1),
                "friction_admissibility": res.residuals.get("friction_admissibility", float("nan")),
                "worst_residual": max(res.residuals.values(), default=float("nan")),
                "solve_time_s": res.solve_time_s,
                "build_time_s": res.build_time_s,
            })
    OUTPUT.mkdir(parents=True, exist_ok=True)
    path = OUTPUT / "table.csv"
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    header = f"{'case':<22} {'run':<26} {'lam':>9} {'it':>4} {'LPs':>4} {'fric.adm':>9} {'worst res':>9} {'time s':>7}  status"
    print(header)
    print("-" * len(header))
    for r in rows:
        lam = "-" if r["multiplier"] is None else f"{r['multiplier']:.5f}"
        print(f"{r['case']:<22} {r['run']:<26} {lam:>9} {r['iterations']:>4} {r['lp_solves']:>4} "
              f"{r['friction_admissibility']:>9.1e} {r['worst_residual']:>9.1e} {r['solve_time_s']:>7.3f}  {r['status']}")
    print(f"\nwritten: {path}")
    return rows


if __name__ == "__main__":
    main()

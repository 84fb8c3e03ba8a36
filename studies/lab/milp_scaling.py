"""How large a structure the ``milp`` method certifies within a time limit.

Two families: square running-bond walls (``n x n`` courses x blocks per course)
and arches on buttresses of growing size.  For each case: time to certify (the
method's timed run: bound LPs + MILP + polish; set-up reported apart), the
status, lam, the dual bound and gap, the node count and lam of the associative
LP for comparison.  Usage::

    python studies/lab/milp_scaling.py [--walls 2,3,2x3,3x2,4,5,6,7,8] [--arches 10:8,20:16,30:35]
                                   [--time-limit 60] [--options multiplier_bounds=0] [--tag fast]

``--arches`` takes ``n_voussoirs:buttress_courses`` pairs.  Writes
``studies/output/milp/milp_scaling[_TAG].csv`` and prints a table.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import blockmpec as bm

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _methods import solve  # noqa: E402
from _tables import write_csv  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "milp"

COLUMNS = ["case", "size", "blocks", "interfaces", "binaries", "status", "certified", "multiplier",
           "associative", "dual_bound", "gap_abs", "nodes", "bound_s", "milp_s", "solve_s", "setup_s",
           "max_residual", "message"]


def run_case(label: str, size: str, structure: bm.Structure, time_limit: float, **options) -> dict:
    """Solve one case with ``milp`` (and ``options``: its options and engine settings) and the associative LP; one
    table row."""
    t0 = time.perf_counter()
    res = solve(structure, "milp", time_limit=time_limit, **options)
    wall_s = time.perf_counter() - t0
    assoc = bm.solve(structure, "static-lp")
    ex = res.extra
    return {
        "case": label, "size": size, "blocks": structure.n_free,
        "interfaces": len(structure.interfaces), "binaries": ex.get("n_binaries"),
        "status": res.status.value, "certified": res.status is bm.Status.OPTIMAL and res.verified,
        "multiplier": res.multiplier, "associative": assoc.multiplier, "dual_bound": ex.get("bound"),
        "gap_abs": ex.get("gap_abs"), "nodes": ex.get("nodes"), "bound_s": ex.get("bound_time_s"),
        "milp_s": ex.get("search_time_s"), "solve_s": res.solve_time_s, "setup_s": res.build_time_s,
        "max_residual": res.max_residual, "message": res.message[:120], "_wall_s": wall_s,
    }


def _fmt(v, width=10):
    if v is None:
        return "-".rjust(width)
    if isinstance(v, bool):
        return str(v).rjust(width)
    if isinstance(v, float):
        return f"{v:.6g}".rjust(width)
    return str(v).rjust(width)


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walls", default="2,3,4,5,6,7,8",
                        help="running-bond walls: n (n x n) or CxB (C courses x B blocks per course)")
    parser.add_argument("--arches", default="10:8,20:16,30:35",
                        help="n_voussoirs:buttress_courses pairs of arch_on_buttresses")
    parser.add_argument("--time-limit", type=float, default=60.0)
    parser.add_argument("--options", default="", help="milp options and engine settings, e.g. multiplier_bounds=0,envelope=1")
    parser.add_argument("--tag", default="", help="suffix of the CSV file name")
    args = parser.parse_args(argv)
    options = {}
    for item in (p for p in args.options.split(",") if p):
        key, value = item.split("=")
        options[key] = {"0": False, "1": True}.get(value, value)
    cases = []
    for spec in (v for v in args.walls.split(",") if v):
        courses, per = (int(p) for p in spec.split("x")) if "x" in spec else (int(spec), int(spec))
        cases.append(("wall", f"{courses}x{per}", bm.cases.wall(courses=courses, blocks_per_course=per)))
    for pair in (p for p in args.arches.split(",") if p):
        nv, nc = (int(v) for v in pair.split(":"))
        cases.append(("arch-on-buttresses", f"{nv}v/{nc}c",
                      bm.cases.arch_on_buttresses(n_voussoirs=nv, buttress_courses=nc)))
    rows = []
    head = ["case", "size", "blocks", "binaries", "status", "multiplier", "associative", "dual_bound", "nodes",
            "solve_s"]
    print(" ".join(h.rjust(18 if h in ("case", "status") else 10) for h in head))
    for label, size, structure in cases:
        row = run_case(label, size, structure, args.time_limit, **options)
        rows.append(row)
        print(" ".join(_fmt(row[h], 18 if h in ("case", "status") else 10) for h in head), flush=True)
    path = write_csv(OUT / f"milp_scaling{'_' + args.tag if args.tag else ''}.csv", rows, COLUMNS)
    for label in dict.fromkeys(r["case"] for r in rows):
        ok = [r["blocks"] for r in rows if r["case"] == label and r["certified"]]
        print(f"largest {label} certified within {args.time_limit:g} s: {max(ok) if ok else 'none'} blocks")
    print(f"wrote {path}")
    return rows


if __name__ == "__main__":
    main()

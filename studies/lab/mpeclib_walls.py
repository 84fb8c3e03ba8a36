"""Every method on MPECLib's six Ferris & Tin-Loi walls (issue 53): lam, status, bound, gap and time.

The walls are the built-in case ``ferris-tinloi`` with ``wall=1..6`` (33 to 146 free blocks; MPECLib's models
``frictionalblock_1`` ... ``_6``).  Each method runs through the public API, ``bm.solve(wall, method,
time_limit=T)``, one after the other in this process; ``milp`` reports its certified lower bound and gap at the stop.
Two tables are printed (and written as markdown): one row per wall as in issue 53 (associative lam, the best exact
point any method found, ``milp``'s stop), and one row per wall and method.

Run it alone on the machine and note the load (it is printed per run): the times are wall seconds.

    nice python studies/lab/mpeclib_walls.py --time-limit 600
    nice python studies/lab/mpeclib_walls.py --walls 1 --methods static-lp,fixed-point,milp --time-limit 60

Writes ``studies/output/mpeclib_walls/runs.jsonl`` (one line per run, as it ends; a rerun skips the runs already
there unless ``--fresh``) and ``table.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import blockmpec as bm

OUT = Path(__file__).resolve().parents[1] / "output" / "mpeclib_walls"
METHODS = ("static-lp", "kinematic-lp", "fixed-point", "slp", "mcp-newton", "nlp", "milp")
#: the best exact point of (3) known to issue 53 per wall (its table; nlp's and milp's polished points)
ISSUE_BEST = {1: 0.6389818, 2: 0.5574159, 3: 0.3558174, 4: 0.2637363, 5: 0.2093015, 6: 0.2959707}


def run(wall: int, method: str, time_limit: float) -> dict:
    """One method on one wall: the row of the long table."""
    structure = bm.cases.build_case("ferris-tinloi", wall=wall)
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    res = bm.solve(structure, method, time_limit=time_limit)
    wall_s = time.perf_counter() - t0
    extra = res.extra or {}
    return {"wall": wall, "blocks": structure.n_free, "interfaces": bm.operators.assemble(structure).n_interfaces,
            "method": method, "status": res.status.value, "verified": bool(res.verified), "lam": res.multiplier,
            "bound": extra.get(bm.facts.BOUND), "gap_rel": extra.get(bm.facts.GAP_REL), "solve_s": res.solve_time_s,
            "wall_s": wall_s, "load": load, "engine": extra.get(bm.facts.ENGINE), "message": res.message[:160]}


def _num(v, digits: int = 7) -> str:
    return "–" if v is None else f"{v:.{digits}f}"


def _bound(v) -> str:
    return "–" if v is None else f"{v:.7g}"


def summary(rows: list[dict]) -> str:
    """Issue 53's table: per wall, the associative lam, the best exact point found (by which method) and milp's stop."""
    lines = ["| wall | free blocks | associative λ | best exact point found (method) | issue 53's best | `milp` |",
             "| --- | ---: | ---: | --- | ---: | --- |"]
    for wall in sorted({r["wall"] for r in rows}):
        mine = [r for r in rows if r["wall"] == wall]
        assoc = next((r["lam"] for r in mine if r["method"] == "static-lp" and r["verified"]), None)
        exact = [r for r in mine if r["method"] not in ("static-lp", "kinematic-lp") and r["verified"]
                 and r["lam"] is not None]
        best = min(exact, key=lambda r: r["lam"]) if exact else None
        milp = next((r for r in mine if r["method"] == "milp"), None)
        stop = "–" if milp is None else (f"{milp['status']} after {milp['solve_s']:.0f} s: λ {_num(milp['lam'])}, "
                                         f"bound {_bound(milp['bound'])}, gap {_num(milp['gap_rel'], 3)}")
        found = "–" if best is None else f"{_num(best['lam'])} ({best['method']})"
        lines.append(f"| {wall} | {mine[0]['blocks']} | {_num(assoc)} | {found} | {ISSUE_BEST.get(wall, '–')} | "
                     f"{stop} |")
    return "\n".join(lines)


def long_table(rows: list[dict]) -> str:
    """One row per wall and method."""
    lines = ["| wall | method | status | verified | λ | bound | gap | solve s | load |",
             "| ---: | --- | --- | --- | ---: | ---: | ---: | ---: | ---: |"]
    for r in sorted(rows, key=lambda r: (r["wall"], METHODS.index(r["method"]) if r["method"] in METHODS else 99)):
        lines.append(f"| {r['wall']} | {r['method']} | {r['status']} | {'yes' if r['verified'] else 'no'} | "
                     f"{_num(r['lam'])} | {_bound(r['bound'])} | {_num(r['gap_rel'], 3)} | {r['solve_s']:.1f} | "
                     f"{r['load']:.1f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", default="1,2,3,4,5,6")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--time-limit", type=float, default=600.0, help="seconds per run")
    ap.add_argument("--fresh", action="store_true", help="run every case again (default: skip those in runs.jsonl)")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    log = args.out / "runs.jsonl"
    rows = [] if args.fresh or not log.exists() else [json.loads(line) for line in log.read_text().splitlines()]
    done = {(r["wall"], r["method"]) for r in rows}
    for wall in (int(w) for w in args.walls.split(",")):
        for method in args.methods.split(","):
            if (wall, method) in done:
                continue
            row = run(wall, method, args.time_limit)
            rows.append(row)
            with log.open("a") as f:
                f.write(json.dumps(row) + "\n")
            print(long_table([row]).splitlines()[-1], flush=True)
    text = f"{summary(rows)}\n\n{long_table(rows)}\n"
    (args.out / "table.md").write_text(text)
    print()
    print(text)


if __name__ == "__main__":
    main()

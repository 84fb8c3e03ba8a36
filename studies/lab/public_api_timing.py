"""Compare two installs through the public API only: the same answers, bit for bit, and the same times.

A restructuring is to leave behaviour and numbers unchanged.  This script uses nothing but ``blockmpec``'s public
API (``bm.cases``, ``bm.solve``, ``bm.run_solver``, ``bm.pushover``, ``Result``'s fields and the comparator's
suite), which exists unchanged before and after, so the same file runs under both installs: run it in each
environment in turn, in one session, and compare the rows.

* Timing rows (``--walls``, ``--methods``): the wall, the method, the status, ``lam`` (full precision), the solve
  time (set-up excluded), the build time, the iterations, the CPU time of the whole ``bm.solve`` call in this
  process (and the Cholesky worker's, where the block IPM ran one), the peak resident memory, whether the verifier
  agreed.
* Answer rows (``--answers suite,heuristic,perf``): every method on the comparator's suite (with its time limits),
  the strategies of the heuristic suite (``heuristic_suite.py``) on its structures, and a subset of the performance
  tables' runs at sizes that reach every engine path (the block IPM, HiGHS's IPM, the interior fixed point, the
  piece LPs, the branch and bound, HiGHS's MILP, the stone walls, pushover curves); each row has the status, ``lam``
  as ``repr``, the iterations, the verdict and the SHA-1 of the solution's vectors.  ``--compare A B`` lists the
  runs whose answers differ between two files of answer rows.

Usage (one environment per install; ``--label`` names it in the rows)::

    python studies/lab/public_api_timing.py --label after --walls 20x50,100x100 --methods static-lp
    python studies/lab/public_api_timing.py --label before --answers suite,heuristic,perf --out before.jsonl
    python studies/lab/public_api_timing.py --compare before.jsonl after.jsonl

Appends JSON lines to ``studies/output/public_api_timing.jsonl`` (``--out``) and prints them.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _tables import peak_memory_mb  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "public_api_timing.jsonl"
#: the fields of an answer row that must agree between two installs
ANSWER_FIELDS = ("status", "multiplier", "iterations", "verified", "solution")


def measure(label: str, courses: int, per_course: int, method: str) -> dict:
    """One solve of the ``courses x per_course`` running-bond wall by ``method``, as a timing row."""
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


# ------------------------------------------------------------------------------------------------- answers
def digest(solution) -> str:
    """SHA-1 (16 hex digits) of a solution's ``x, u, z_u, z_f``."""
    h = hashlib.sha1()
    for name in ("x", "u", "z_u", "z_f"):
        v = getattr(solution, name, None)
        h.update(name.encode())
        if v is not None:
            h.update(np.ascontiguousarray(np.asarray(v, float)).tobytes())
    return h.hexdigest()[:16]


def answer(label: str, group: str, case: str, structure, method: str, options=None, settings=None) -> dict:
    """One run (``settings``: the method's engine settings, by name) as an answer row."""
    options = dict(options or {})
    if settings is None:
        res = bm.solve(structure, method, **options)
    else:
        cls = bm.get_solver(method)
        res = bm.run_solver(cls(settings=cls.Settings(**settings), **options), structure)
    return {"label": label, "group": group, "case": case, "method": method, "options": options, "settings": settings,
            "status": res.status.value, "multiplier": None if res.multiplier is None else repr(float(res.multiplier)),
            "iterations": res.iterations, "verified": bool(res.verified), "solution": digest(res.solution),
            "solve_s": res.solve_time_s}


def suite_runs():
    """Every method on the comparator's suite, with the comparator's time limits."""
    from blockmpec.bench.compare import BENCHMARK_METHOD_OPTIONS
    from blockmpec.bench.suite import BENCHMARK_SUITE

    for case, (name, params) in BENCHMARK_SUITE.items():
        structure = bm.build_case(name, **params)
        for method in ("kinematic-lp", "static-lp", "fixed-point", "mcp-newton", "milp", "nlp", "slp"):
            yield case, structure, method, BENCHMARK_METHOD_OPTIONS.get(method, {}), None


def heuristic_runs():
    """The heuristics (and, where a certificate is in reach, ``milp``) on the heuristic suite's structures."""
    from heuristic_suite import suite

    for entry in suite():
        structure = entry.build()
        runs = [("fixed-point", {}), ("fixed-point", {"start": "associative", "tie_break": "closest"}),
                ("mcp-newton", {"time_limit": 60.0}), ("nlp", {"time_limit": 60.0}), ("slp", {})]
        if entry.source != "best verified":
            runs.append(("milp", {"time_limit": 90.0}))
        for method, options in runs:
            yield entry.label, structure, method, options, None


def stone_wall(stones: int, irregularity: float = 0.5):
    height = 0.3 * math.sqrt(stones / 2.0)
    return bm.cases.stone_wall(width=2.0 * height, height=height, stone_size=0.3, irregularity=irregularity)


def perf_runs():
    """Runs of the performance tables' kinds at sizes that reach every engine path."""
    w = bm.cases.wall
    yield from ((f"wall-20x50 {o}", w(20, 50), "static-lp", o, None)
                for o in ({}, {"algorithm": "ipm"}, {"algorithm": "block-ipm"}))
    yield "wall-20x50", w(20, 50), "kinematic-lp", {}, None
    yield "wall-20x50", w(20, 50), "fixed-point", {}, None
    yield "wall-20x50", w(20, 50), "fixed-point", {"engine": "interior"}, {"interior_weight": 0.0}
    yield "wall-32x63", w(32, 63), "static-lp", {}, None
    yield "wall-32x63", w(32, 63), "fixed-point", {}, None
    yield "wall-32x63", w(32, 63), "nlp", {"time_limit": 120.0}, None
    for piece_lps in ("split", "whole"):
        yield "wall-20x25", w(20, 25), "nlp", {"route": "pieces", "time_limit": 60.0}, {"piece_lps": piece_lps}
    yield "wall-10x5", w(10, 5), "nlp", {"time_limit": 60.0}, {"piece_lp": True}
    yield "wall-10x5", w(10, 5), "nlp", {"complementarity": "penalty", "start": "fixed-point", "time_limit": 60.0}, None
    yield "wall-10x5", w(10, 5), "slp", {"alpha_schedule": "halving"}, None
    yield "wall-10x5", w(10, 5), "static-lp", {"algorithm": "primal-simplex"}, None
    yield "wall-10x5", w(10, 5), "kinematic-lp", {"algorithm": "ipm"}, None
    for courses, per_course in ((2, 4), (4, 3), (5, 2)):
        yield f"wall-{courses}x{per_course}", w(courses, per_course), "milp", {"time_limit": 120.0}, None
    yield "wall-3x2", w(3, 2), "milp", {"engine": "highs", "time_limit": 120.0}, None
    yield "wall-3x2", w(3, 2), "milp", {"sense": "max", "time_limit": 120.0}, None
    for method, options in (("static-lp", {}), ("kinematic-lp", {}), ("fixed-point", {}),
                            ("nlp", {"time_limit": 120.0}), ("mcp-newton", {"time_limit": 60.0})):
        yield "stone-200", stone_wall(200), method, options, None
    yield "stone-600", stone_wall(600, 0.7), "static-lp", {}, None


def curve_rows(label: str) -> list[dict]:
    """Pushover curves (every column but the times), hashed."""
    rows = []
    for case, method, steps in ((bm.cases.round_arch(), "static-lp", 4), (bm.cases.wall(4, 3), "fixed-point", 4),
                                (bm.cases.round_arch(), "fixed-point", 10)):
        curve = bm.pushover(case, method=method, steps=steps)
        text = curve.drop(columns=[c for c in curve.columns if "time" in c]).to_csv()
        rows.append({"label": label, "group": "perf", "case": f"pushover {case.name} steps={steps}", "method": method,
                     "options": {}, "settings": None, "status": curve.attrs["stop_reason"], "multiplier": None,
                     "iterations": len(curve), "verified": None, "solution": hashlib.sha1(text.encode()).hexdigest()[:16],
                     "solve_s": 0.0})
    return rows


def answers(label: str, groups: list[str], first: int | None = None):
    """The answer rows of ``groups``, one by one (``first``: only each group's first runs)."""
    from itertools import islice

    runs = {"suite": suite_runs, "heuristic": heuristic_runs, "perf": perf_runs}
    for group in groups:
        for case, structure, method, options, settings in islice(runs[group](), first):
            yield answer(label, group, case, structure, method, options, settings)
        if group == "perf" and first is None:
            yield from curve_rows(label)


def compare(before: Path, after: Path) -> int:
    """Print the runs whose answers differ; the number of differing runs."""
    def rows(path):
        out = {}
        for line in path.read_text().splitlines():
            r = json.loads(line)
            if "group" in r:
                out[(r["group"], r["case"], r["method"], json.dumps(r["options"], sort_keys=True),
                     json.dumps(r["settings"], sort_keys=True))] = r
        return out

    a, b = rows(before), rows(after)
    differ = 0
    for key in a.keys() & b.keys():
        changed = {f: (a[key][f], b[key][f]) for f in ANSWER_FIELDS if a[key][f] != b[key][f]}
        if changed:
            differ += 1
            print("differs:", key[:4], changed, f"solve {a[key]['solve_s']:.1f} / {b[key]['solve_s']:.1f} s")
    print(f"{len(a.keys() & b.keys()) - differ} runs the same, {differ} differ, {len(a.keys() ^ b.keys())} in one "
          "file only")
    return differ


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--label", help="names the install in the rows (e.g. before, after)")
    parser.add_argument("--walls", default="20x50", help="comma-separated CxB running-bond walls (default 20x50)")
    parser.add_argument("--methods", default="static-lp", help="comma-separated methods (default static-lp)")
    parser.add_argument("--answers", help="answer rows instead of timing rows: comma-separated suite,heuristic,perf")
    parser.add_argument("--first", type=int, help="with --answers: only the first N runs of each group")
    parser.add_argument("--compare", nargs=2, type=Path, metavar=("BEFORE", "AFTER"),
                        help="list the runs whose answers differ between two files of answer rows")
    parser.add_argument("--out", type=Path, default=OUT, help=f"JSON-lines file to append to (default {OUT})")
    args = parser.parse_args(argv)
    if args.compare:
        return 1 if compare(*args.compare) else 0
    if not args.label:
        parser.error("--label is required (unless --compare)")
    try:
        walls = [tuple(int(v) for v in w.split("x")) for w in args.walls.split(",")]
    except ValueError:
        parser.error(f"--walls {args.walls}: expected CxB,CxB,... (e.g. 20x50)")
    if args.answers:
        rows = answers(args.label, args.answers.split(","), args.first)
    else:
        rows = (measure(args.label, c, b, m) for c, b in walls for m in args.methods.split(","))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    for row in rows:
        print(json.dumps(row), flush=True)
        with args.out.open("a") as f:
            f.write(json.dumps(row) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

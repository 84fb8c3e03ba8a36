"""The piece-LP descent of ``nlp`` from one fixed point, per route and LP engine: lam, LP seconds, certificate.

For each running-bond wall (``--walls``) the registered ``fixed-point`` method is solved once; from its
solution of (3) the piece descent runs per engine (``--engines``): ``whole`` (each piece one HiGHS LP,
:func:`~blockmpec.solvers.engines.piece_lp.whole_piece_descent`, the route before the split) and the split
descent (:func:`~blockmpec.solvers.engines.piece_lp.piece_descent`) with its static halves by
``dual-simplex`` (HiGHS, vertices, warm) or ``block-ipm``.  Per run: status, certified, lam, process CPU and
wall seconds, LP solves, seconds in the static and kinematic halves, the verifier's largest residual.
Usage::

    python studies/lab/piece_lp_engines.py [--walls 10x10,15x15,20x25,32x63] [--engines whole,dual-simplex,block-ipm]
                                       [--time-limit 120] [--tag T]

Writes ``studies/output/nlp/piece_lp_engines[_TAG].csv`` and prints a markdown table.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import blockmpec as bm

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _tables import csv_rows  # noqa: E402
from _walls import wall_shapes  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "nlp"
COLUMNS = ["wall", "blocks", "pairs", "engine", "status", "certified", "multiplier", "fixed_point", "cpu_s", "wall_s",
           "lp_solves", "static_s", "kinematic_s", "residual", "message"]


def run(courses: int, per_course: int, engines: list[str], time_limit: float, append) -> list[dict]:
    """Every engine's descent from one fixed point of one wall."""
    from blockmpec.deadline import Deadline
    from blockmpec.formulations import compile_mcp
    from blockmpec.solvers.engines.piece_lp import piece_descent, whole_piece_descent
    from blockmpec.solvers.engines.scaling import LoadUnits
    from blockmpec.solvers.nlp import without_free_sliding
    from blockmpec.verify import residuals

    case = bm.cases.wall(courses=courses, blocks_per_course=per_course)
    ops = bm.assemble(case)
    form = compile_mcp(ops)
    scaling = LoadUnits.of(ops).mcp(form)
    fp = bm.solve(case, "fixed-point")
    w0 = form.pack(fp.solution)
    rows = []
    for engine in engines:
        c0, t0 = time.process_time(), time.perf_counter()
        if engine == "whole":
            out = whole_piece_descent(form, scaling, w0, deadline=Deadline(time_limit))
        else:
            out = piece_descent(form, scaling, w0, deadline=Deadline(time_limit), static_engine=engine)
        cpu, wall = time.process_time() - c0, time.perf_counter() - t0
        residual = None
        if out.w is not None:
            solution = without_free_sliding(form, form.unpack(out.w))
            residual = max(residuals(ops, solution, associative=False).values())
        row = {"wall": f"{courses}x{per_course}", "blocks": case.n_free, "pairs": form.n_pairs, "engine": engine,
               "status": out.status.value, "certified": out.certified, "multiplier": out.multiplier,
               "fixed_point": fp.multiplier, "cpu_s": cpu, "wall_s": wall, "lp_solves": out.lp_solves,
               "static_s": out.static_time_s if engine != "whole" else None,
               "kinematic_s": out.kinematic_time_s if engine != "whole" else None, "residual": residual,
               "message": out.message[:120]}
        append(row)
        rows.append(row)
        print(row, flush=True)
    return rows


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", default="10x10,15x15,20x25,32x63")
    ap.add_argument("--engines", default="whole,dual-simplex,block-ipm")
    ap.add_argument("--time-limit", type=float, default=120.0)
    ap.add_argument("--tag", default="")
    args = ap.parse_args(argv)
    walls = wall_shapes(args.walls)
    engines = [e.strip() for e in args.engines.split(",") if e.strip()]
    rows = []
    with csv_rows(OUT / f"piece_lp_engines{'_' + args.tag if args.tag else ''}.csv", COLUMNS) as append:
        for courses, per_course in walls:
            rows += run(courses, per_course, engines, args.time_limit, append)
    print("\n| wall (blocks, pairs) | fixed point λ | " + " | ".join(engines) + " |")
    print("|---|---|" + "---|" * len(engines))
    for wall in dict.fromkeys(r["wall"] for r in rows):
        mine = {r["engine"]: r for r in rows if r["wall"] == wall}
        first = next(iter(mine.values()))
        cells = []
        for e in engines:
            r = mine[e]
            mark = "" if r["certified"] else "*"
            cells.append(f"{r['cpu_s']:.1f} s, λ {r['multiplier']:.5f}{mark}")
        print(f"| {wall} ({first['blocks']}, {first['pairs']}) | {first['fixed_point']:.5f} | " + " | ".join(cells) + " |")
    print("(CPU seconds of the descent alone, the fixed point excluded; * = not certified)")
    return rows


if __name__ == "__main__":
    main()

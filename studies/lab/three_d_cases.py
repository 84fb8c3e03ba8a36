"""The built-in 3D cases (issue 52): the pyramid against the exact cone, and associative against non-associative.

Two tables:

* ``cases``: per 3D case (``--cases``): free blocks, contact points, ``static-lp``'s lam with the default 4-sided
  inscribed pyramid and with 8 sides, the exact cone's lam (Clarabel, :func:`blockmpec.three_d.cone.exact_cone`) and the
  4-sided pyramid's relative error, then ``fixed-point``'s lam, status and time (``--no-fixed-point`` leaves it out);
* ``extruded``: every 2D built-in case extruded to ``--thickness``: 2D and 3D ``static-lp`` and ``fixed-point``
  multipliers side by side and their differences (the associative ones agree to round-off; the fixed point's solution
  of (3) is not unique, and a 3D value below the 2D one would be a finding).

Usage::

    python studies/lab/three_d_cases.py
    python studies/lab/three_d_cases.py --cases dome,corner-wall --no-fixed-point
    python studies/lab/three_d_cases.py --smoke          # the single block and the extruded two blocks, checked

Needs Clarabel for the cone (``pip install "blockmpec[cone]"``).  Writes ``studies/output/three_d_cases/*.csv``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import blockmpec as bm
from blockmpec.three_d import cases as c3
from blockmpec.three_d.cone import exact_cone

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from _tables import markdown, write_csv  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "three_d_cases"
CASE_COLUMNS = [("case", "case", "{}"), ("blocks", "free blocks", "{}"), ("points", "contact points", "{:,}"),
                ("pyramid4", "lam, pyramid 4", "{:.5f}"), ("pyramid8", "lam, pyramid 8", "{:.5f}"),
                ("cone", "lam, cone", "{:.5f}"), ("error4", "pyramid 4 error", "{:.1%}"),
                ("fixed_point", "lam (3), fixed point", "{:.5f}"), ("fp_status", "status", "{}"),
                ("fp_s", "time [s]", "{:.1f}")]
EXTRUDED_COLUMNS = [("case", "case", "{}"), ("lp_2d", "static-lp 2D", "{:.8f}"), ("lp_3d", "static-lp 3D", "{:.8f}"),
                    ("lp_diff", "difference", "{:.1e}"), ("fp_2d", "fixed-point 2D", "{:.8f}"),
                    ("fp_3d", "fixed-point 3D", "{:.8f}"), ("fp_diff", "difference", "{:.1e}"),
                    ("fp_3d_verified", "3D verified", "{}")]


def case_row(name: str, fixed_point: bool, time_limit: float) -> dict:
    s = bm.build_case(name)
    ops = bm.assemble(s)
    cone = exact_cone(s)
    eight = bm.solve(s.with_loads(pyramid_sides=8), "static-lp")
    row = {"case": name, "blocks": s.n_free, "points": ops.n_contacts, "pyramid4": cone.inscribed,
           "pyramid8": eight.multiplier, "cone": cone.multiplier, "error4": cone.relative_error}
    if fixed_point:
        t0 = time.perf_counter()
        fp = bm.solve(s, "fixed-point", time_limit=time_limit)
        row.update(fixed_point=fp.multiplier, fp_status=f"{fp.status.value}{'' if fp.verified else ' (unverified)'}",
                   fp_s=time.perf_counter() - t0)
    return row


def extruded_row(name: str, thickness: float, time_limit: float) -> dict:
    two = bm.build_case(name)
    three = c3.extrude(two, thickness)
    row = {"case": name}
    for key, s in (("2d", two), ("3d", three)):
        row[f"lp_{key}"] = bm.solve(s, "static-lp").multiplier
        fp = bm.solve(s, "fixed-point", time_limit=time_limit)
        row[f"fp_{key}"], row[f"fp_{key}_verified"] = fp.multiplier, fp.verified
    row["lp_diff"] = row["lp_3d"] - row["lp_2d"]
    row["fp_diff"] = row["fp_3d"] - row["fp_2d"]
    return row


def main(argv: list[str] | None = None) -> tuple[list[dict], list[dict]]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", default=",".join(c3.CASES_3D), help="comma-separated 3D cases")
    ap.add_argument("--extruded", default="two-blocks,single-block,round-arch,arch-on-buttresses,wall,ferris-tinloi")
    ap.add_argument("--thickness", type=float, default=1.0)
    ap.add_argument("--no-fixed-point", action="store_true")
    ap.add_argument("--time-limit", type=float, default=600.0)
    ap.add_argument("--smoke", action="store_true")
    args = ap.parse_args(argv)
    names = ["block-3d"] if args.smoke else [c for c in args.cases.split(",") if c]
    extruded = ["two-blocks"] if args.smoke else [c for c in args.extruded.split(",") if c]
    cases = [case_row(n, not args.no_fixed_point, args.time_limit) for n in names]
    print(markdown(cases, CASE_COLUMNS))
    write_csv(OUT / "cases.csv", cases)
    rows = [extruded_row(n, args.thickness, args.time_limit) for n in extruded]
    print(markdown(rows, EXTRUDED_COLUMNS))
    write_csv(OUT / "extruded.csv", rows)
    if args.smoke:
        assert abs(cases[0]["cone"] - 0.5) < 1e-8 and abs(cases[0]["pyramid4"] - 0.5) < 1e-9, cases
        assert abs(rows[0]["lp_diff"]) < 1e-8 and abs(rows[0]["fp_diff"]) < 1e-8, rows
    return cases, rows


if __name__ == "__main__":
    main()

"""3D structures at scale (issue 52): contact detection, assembly, the associative LP and the fixed point.

Each structure (but the ``--domes``) is a two-leaf 3D running-bond wall of about ``--sizes`` blocks
(:func:`bonded_wall`: two leaves of bricks side by side in ``y``, the courses alternating stretchers and headers, so
that contacts lie in all three planes), built in this process one after the other:

* ``build_s``: :func:`blockmpec.three_d.make_structure_3d` (checks, overlaps and the contact detection), of which
  ``contacts_s`` is the contact detection alone (:func:`blockmpec.three_d.contacts.detect_contacts`);
* ``assemble_s``: the operators (:func:`blockmpec.assemble`);
* ``static-lp``: its solve time (set-up apart), the engine its plan chose and lam;
* with ``--fixed-point`` (sizes up to ``--fixed-point-max``): ``fixed-point``'s solve time, the engine its plan chose
  (the LP steps below 500 free blocks, the interior engine from there), its iterations, status and lam.

Usage::

    python studies/lab/three_d_scale.py                                   # 100, 1,000 and 10,000 blocks
    python studies/lab/three_d_scale.py --fixed-point --fixed-point-max 10000
    python studies/lab/three_d_scale.py --sizes= --domes 10x20,20x40 --fixed-point --time-limit 300
    python studies/lab/three_d_scale.py --smoke                           # 60 blocks, every step, checked

Prints a markdown table and writes ``studies/output/three_d_scale/scale.csv``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm
from blockmpec.three_d import box, make_structure_3d
from blockmpec.three_d.contacts import detect_contacts

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from _tables import markdown, peak_memory_mb, write_csv  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "three_d_scale"


def bonded_wall(blocks: int, mu: float = 0.65) -> bm.three_d.Structure3D:
    """A two-leaf brick wall (bricks 0.4 x 0.2 x 0.1, leaves 0.2 deep) of about ``blocks`` bricks on a fixed base: even
    courses are stretchers in both leaves, odd courses a row of headers across both, offset by half a header; live
    load out of plane (``+y``)."""
    per_course = max(2, int(round((blocks / 2) ** 0.5)))
    courses = max(2, blocks // (2 * per_course))
    length = 0.4 * per_course
    bricks = []
    for k in range(courses):
        z0, z1 = 0.1 * k, 0.1 * (k + 1)
        if k % 2 == 0:
            for leaf in (0, 1):
                for j in range(per_course):
                    bricks.append(box((0.4 * j, 0.2 * leaf, z0), (0.4 * (j + 1), 0.2 * (leaf + 1), z1)))
        else:
            edges = np.concatenate([[0.0], np.arange(0.1, length, 0.2), [length]])
            for x0, x1 in zip(edges[:-1], edges[1:]):
                bricks.append(box((x0, 0.0, z0), (x1, 0.4, z1)))
    base = box((-0.2, -0.2, -0.2), (length + 0.2, 0.6, 0.0))
    return make_structure_3d([base] + bricks, [True] + [False] * len(bricks), friction=mu,
                             live_direction=[0.0, 1.0, 0.0], name=f"bonded-wall-{len(bricks)}")


def dome_of(size: str) -> bm.three_d.Structure3D:
    """The built-in dome with ``RINGSxSEGMENTS`` voussoirs (``"20x40"``: 800)."""
    rings, segments = (int(v) for v in size.split("x"))
    return bm.three_d.cases.dome(rings=rings, segments=segments)


def measure(blocks: int | str, fixed_point: bool, time_limit: float) -> dict:
    """One row: a bonded wall of about ``blocks`` bricks, or the dome ``"RINGSxSEGMENTS"``."""
    t0 = time.perf_counter()
    s = bonded_wall(blocks) if isinstance(blocks, int) else dome_of(blocks)
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    detect_contacts(s.vertices, s.faces)
    contacts = time.perf_counter() - t0
    t0 = time.perf_counter()
    ops = bm.assemble(s)
    assemble = time.perf_counter() - t0
    row = {"structure": "wall" if isinstance(blocks, int) else f"dome {blocks}", "blocks": s.n_free,
           "contacts": len(s.contacts), "points": ops.n_contacts, "build_s": build, "contacts_s": contacts,
           "assemble_s": assemble}
    lp = bm.solve(ops, "static-lp", time_limit=time_limit)
    row.update(lp_s=lp.solve_time_s, lp_status=lp.status.value, lp_verified=lp.verified, lam=lp.multiplier,
               lp_plan="; ".join(lp.extra.get("plan", [])))
    if fixed_point:
        fp = bm.solve(ops, "fixed-point", time_limit=time_limit)
        row.update(fp_s=fp.solve_time_s, fp_engine=fp.extra.get("engine", ""), fp_steps=fp.iterations,
                   fp_status=fp.status.value, fp_verified=fp.verified, fp_lam=fp.multiplier)
    row["peak_mb"] = peak_memory_mb()
    return row


COLUMNS = [("structure", "structure", "{}"), ("blocks", "blocks", "{:,}"), ("contacts", "contacts", "{:,}"),
           ("points", "points", "{:,}"),
           ("build_s", "build [s]", "{:.2f}"), ("contacts_s", "contacts [s]", "{:.2f}"),
           ("assemble_s", "assemble [s]", "{:.2f}"), ("lp_s", "static-lp [s]", "{:.2f}"), ("lam", "lam", "{:.6f}"),
           ("lp_plan", "static-lp engine", "{}"), ("fp_s", "fixed-point [s]", "{:.1f}"),
           ("fp_engine", "fixed-point engine", "{}"), ("fp_steps", "iterations", "{}"),
           ("fp_status", "fixed-point", "{}"), ("fp_verified", "verified", "{}"), ("fp_lam", "lam (3)", "{:.6f}"),
           ("peak_mb", "peak [MB]", "{:.0f}")]


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="100,1000,10000", help="comma-separated numbers of blocks")
    ap.add_argument("--domes", default="",
                    help="comma-separated domes RINGSxSEGMENTS (e.g. 10x20,20x40), after the walls")
    ap.add_argument("--fixed-point", action="store_true", help="also the fixed point (sizes up to --fixed-point-max)")
    ap.add_argument("--fixed-point-max", type=int, default=2000)
    ap.add_argument("--time-limit", type=float, default=600.0)
    ap.add_argument("--smoke", action="store_true", help="60 blocks, every step, checked")
    args = ap.parse_args(argv)
    sizes = [60] if args.smoke else [int(v) for v in args.sizes.split(",") if v]
    domes = [] if args.smoke else [v for v in args.domes.split(",") if v]
    rows = [measure(n, (args.fixed_point or args.smoke) and n <= args.fixed_point_max, args.time_limit)
            for n in sizes]
    rows += [measure(d, args.fixed_point, args.time_limit) for d in domes]
    print(markdown(rows, COLUMNS))
    write_csv(OUT / "scale.csv", rows)
    if args.smoke:
        row = rows[0]
        assert row["lp_verified"] and row["fp_verified"], row
        assert row["fp_lam"] <= row["lam"] * (1 + 1e-9), row  # every solution of (3) lies below the associative lam
    return rows


if __name__ == "__main__":
    main()

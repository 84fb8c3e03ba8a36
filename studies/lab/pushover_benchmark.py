"""Capacity curves (``bm.pushover``): the time per configuration against one solve of the undeformed structure.

For each case and method, one capacity curve with ``--steps`` steps up to the default
``max_displacement`` (half the median shorter side of the free blocks), and, apart, the undeformed
structure solved ``--repeat`` times by ``bm.solve`` (assembly, Pyomo build and solve; median wall
time).  Each row of a curve is one configuration: contacts found, the deformed structure assembled,
built and solved, and the blocks moved (the second-order correction, cuts at contact events and at
instabilities, the dead-load LP when a configuration does not stand, the fixed point's retries).
Reported per curve:

* ``rows``: configurations solved (``steps + 1`` unless the curve was cut at events or stopped);
* ``s/row`` and ``s/row / solve``: the curve's wall time per row, and that over one undeformed solve;
* ``lam0``, ``lam_last``: the multiplier of the undeformed structure and of the last configuration
  that stands; ``ultimate``: the displacement where ``lam`` reaches 0 (interpolated), if it does;
* ``snaps``: rows reached by falling under the dead load; ``stop``: why the curve ended;
* with ``--sensitivity``, ``dlam(c/10)``: the largest change of ``lam`` over the configurations reached
  by full steps when the point contacts' length (``contact_length``) is divided by ten (the same
  positions, solved again; see :mod:`blockmpec.contacts` for the bound), and ``failed (c/10)``: how
  many of them then no longer stand or fail to solve.

Usage::

    python studies/lab/pushover_benchmark.py [--cases round-arch,arch-on-buttresses,wall-5x4,wall-10x5]
        [--methods static-lp,fixed-point] [--steps 10] [--repeat 3] [--sensitivity]

Prints a markdown table and writes ``studies/output/pushover_benchmark/pushover_<steps>.csv``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm
from blockmpec.contacts import CONTACT_LENGTH, contact_structure, find_contacts
from blockmpec.pushover import block_polygons

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _tables import markdown, write_csv  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "pushover_benchmark"

CASES = {
    "round-arch": lambda: bm.cases.round_arch(),
    "arch-on-buttresses": lambda: bm.cases.arch_on_buttresses(),
    "wall-5x4": lambda: bm.cases.wall(5, 4),
    "wall-10x5": lambda: bm.cases.wall(10, 5),
}

COLUMNS = [
    ("case", "case", "{}"), ("method", "method", "{}"), ("free_blocks", "free blocks", "{:d}"),
    ("rows", "rows", "{:d}"), ("snaps", "snaps", "{:d}"), ("curve_s", "curve s", "{:.2f}"),
    ("s_per_row", "s/row", "{:.3f}"), ("solve_s", "undeformed solve s", "{:.3f}"),
    ("ratio", "s/row / solve", "{:.1f}"), ("lam0", "lam0", "{:.5f}"), ("lam_last", "lam last", "{:.5f}"),
    ("ultimate", "ultimate", "{:.4g}"), ("dlam_c10", "dlam(c/10)", "{:.1e}"), ("c10_failed", "failed (c/10)", "{:d}"),
    ("stop", "stop", "{}"),
]


def undeformed_solve_s(structure, method: str, repeat: int) -> float:
    """Median wall time of ``bm.solve`` on the undeformed structure (assembly, build and solve)."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        bm.solve(structure, method)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def contact_sensitivity(structure, method: str, curve, factor: float = 0.1) -> tuple[float, int]:
    """Largest ``|lam - lam'|`` over the configurations of ``curve`` reached by full steps that stand, ``lam'``
    with the point contacts ``factor`` times as long (same block positions, contacts found again), and how
    many of them no longer stand or failed (a configuration cut back to an instability stands by a hair,
    so those are left out)."""
    worst, failed = 0.0, 0
    base = structure
    full = curve["event"].isin(["start", "step"]).to_numpy() & np.isfinite(curve["multiplier"].to_numpy(float))
    for row in np.flatnonzero(full):
        polygons = block_polygons(base, curve, int(row))
        vertices = np.array(base.vertices)
        for i, p in enumerate(polygons):
            vertices[i, : len(p)] = p
            vertices[i, len(p):] = p[-1]
        contacts = find_contacts(vertices, base.n_vertices, base.fixed,
                                 tolerance=curve.attrs["contact_tolerance"], contact_length=factor * CONTACT_LENGTH)
        res = bm.solve(contact_structure(base, vertices, contacts), method)
        if not res.success:
            failed += 1
            continue
        worst = max(worst, abs(res.multiplier - curve["multiplier"].iloc[row]))
    return worst, failed


def _short(reason: str) -> str:
    """The stop reason without its details (the solver's message, the snaps' count)."""
    return reason.split(":")[0] if reason.startswith("the structure collapses") else reason.split(" (")[0]


def run(cases: list[str], methods: list[str], steps: int, repeat: int, sensitivity: bool) -> list[dict]:
    rows = []
    for name in cases:
        structure = CASES[name]()
        for method in methods:
            solve_s = undeformed_solve_s(structure, method, repeat)
            t0 = time.perf_counter()
            curve = bm.pushover(structure, method, steps=steps)
            curve_s = time.perf_counter() - t0
            solved = curve["multiplier"].to_numpy(float)
            solved = solved[np.isfinite(solved)]
            standing = solved[solved > 0]
            row = dict(
                case=name, method=method, free_blocks=structure.n_free, rows=len(curve),
                snaps=int((curve["event"] == "snap").sum()), curve_s=curve_s, s_per_row=curve_s / len(curve),
                solve_s=solve_s, ratio=curve_s / len(curve) / solve_s, lam0=float(curve["multiplier"].iloc[0]),
                lam_last=float(standing[-1]) if standing.size else float("nan"),
                ultimate=curve.attrs["ultimate_displacement"], stop=_short(curve.attrs["stop_reason"]),
            )
            if sensitivity:
                row["dlam_c10"], row["c10_failed"] = contact_sensitivity(structure, method, curve)
            rows.append(row)
            print(f"{name} {method}: {len(curve)} rows in {curve_s:.1f} s", flush=True)
    return rows


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default=",".join(CASES), help=f"comma-separated, of {', '.join(CASES)}")
    parser.add_argument("--methods", default="static-lp,fixed-point", help="comma-separated methods")
    parser.add_argument("--steps", type=int, default=10, help="steps of each curve (default 10)")
    parser.add_argument("--repeat", type=int, default=3, help="undeformed solves timed per case and method (median)")
    parser.add_argument("--sensitivity", action="store_true",
                        help="also solve each configuration with point contacts ten times shorter")
    args = parser.parse_args(argv)
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        parser.error(f"--cases: unknown case {unknown[0]!r}; choose from {', '.join(CASES)}")
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    rows = run(cases, methods, args.steps, args.repeat, args.sensitivity)
    print()
    print(markdown(rows, [c for c in COLUMNS if args.sensitivity or c[0] not in ("dlam_c10", "c10_failed")]))
    path = write_csv(OUT / f"pushover_{args.steps}.csv", rows, [c[0] for c in COLUMNS])
    print(f"\nwrote {path}")
    return rows


if __name__ == "__main__":
    main()

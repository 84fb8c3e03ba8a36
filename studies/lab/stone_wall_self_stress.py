"""Self-stress in irregular stone walls, and what it does to the static LP's interior-point engine.

On a wall of wedged stones with enough friction, interface forces can be in equilibrium with no load at all
(``E x = 0``) while satisfying every row of the static LP (1) (no tension, rocking and Coulomb rows) and
compressing some interfaces: a *self-stress*.  Adding any multiple of one to an optimal ``x`` of (1) keeps it
optimal, so (1)'s optimal face is unbounded; ``lam`` and the mechanism are unaffected, but an interior-point
method has no end point to converge to.  For each ``stone-wall`` (about ``--stones`` stones, 2:1, mean stone
size 0.3) and friction coefficient ``--mus``, this study measures:

* ``self_stress``: the largest ``-sum_k n_k`` over self-stresses with ``-n_k <= 1`` per interface (HiGHS), and how
  many interfaces it compresses (0: none exists);
* ``static-lp`` with ``algorithm="block-ipm"`` (the block IPM alone) and with ``"auto"`` (the block IPM, then
  HiGHS's interior point with crossover when it fails): status and ``lam``;
* with ``--reference``, ``static-lp`` by HiGHS's interior point (``algorithm="ipm"``) as the reference ``lam``.

Usage::

    python studies/lab/stone_wall_self_stress.py                       # 500/1000/2000 stones, mu 0.65..1.2
    python studies/lab/stone_wall_self_stress.py --stones 500 --mus 0.65,1.0 --smoke

``--smoke`` checks that ``auto`` ends ``optimal`` on every row and agrees with the reference within 1e-8
(relative).  Prints a markdown
table and writes ``studies/output/stone_wall_self_stress/self_stress.csv``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import scipy.sparse as sp

import blockmpec as bm
from blockmpec.solvers.engines.highs import solve_lp

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from _tables import markdown, write_csv  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "stone_wall_self_stress"


def largest_self_stress(ops) -> tuple[float, int]:
    """``max -sum n`` over ``E x = 0``, ``N_u^T x <= 0``, ``N_f^T x <= 0``, ``-n_k <= 1`` (HiGHS), and the number
    of interfaces with ``n_k < -1e-6`` at the optimum."""
    E, N_u, N_f = ops.E, ops.N_u, ops.N_f
    columns = E.shape[1]
    interfaces = columns // 3
    normal = sp.csr_array((np.ones(interfaces), (np.arange(interfaces), np.arange(1, columns, 3))),
                          shape=(interfaces, columns))
    A = sp.vstack([E, N_u.T, N_f.T, -normal]).tocsc()
    rows_eq, rows_in = E.shape[0], N_u.shape[1] + N_f.shape[1]
    row_lower = np.r_[np.zeros(rows_eq), np.full(rows_in + interfaces, -np.inf)]
    row_upper = np.r_[np.zeros(rows_eq + rows_in), np.ones(interfaces)]
    cost = np.zeros(columns)
    cost[1::3] = 1.0  # min sum n = max compression
    status, x, value = solve_lp(cost, A, row_lower, row_upper, np.full(columns, -np.inf), np.full(columns, np.inf))
    if x is None:
        raise RuntimeError(f"self-stress LP: {status.value}")
    return max(0.0, -value), int(np.sum(x[1::3] < -1e-6))


def wall(stones: int, irregularity: float, mu: float, seed: int) -> bm.Structure:
    height = 0.3 * math.sqrt(stones / 2.0)
    return bm.cases.stone_wall(width=2.0 * height, height=height, stone_size=0.3, irregularity=irregularity,
                               seed=seed, mu=mu)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stones", default="500,1000,2000", help="comma-separated stone counts")
    parser.add_argument("--irregularities", default="0.5,0.7")
    parser.add_argument("--mus", default="0.65,0.8,1.0,1.2")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--reference", action="store_true", help="also static-lp by HiGHS's interior point")
    parser.add_argument("--smoke", action="store_true", help="check auto against the reference (implies --reference)")
    args = parser.parse_args(argv)
    reference = args.reference or args.smoke
    rows = []
    for stones in [int(s) for s in args.stones.split(",")]:
        for irregularity in [float(r) for r in args.irregularities.split(",")]:
            for mu in [float(m) for m in args.mus.split(",")]:
                structure = wall(stones, irregularity, mu, args.seed)
                ops = bm.assemble(structure)
                stress, compressed = largest_self_stress(ops)
                alone = bm.solve(structure, "static-lp", algorithm="block-ipm")
                auto = bm.solve(structure, "static-lp")
                row = {"stones": structure.n_blocks - int(structure.fixed.sum()), "irregularity": irregularity,
                       "mu": mu, "self_stress": round(stress, 6), "compressed_interfaces": compressed,
                       "block_ipm_status": alone.status.value, "block_ipm_lam": alone.multiplier,
                       "auto_status": auto.status.value, "auto_lam": auto.multiplier,
                       "auto_plan": " / ".join(auto.extra.get("plan", [])), "auto_s": round(auto.solve_time_s, 2)}
                if reference:
                    ref = bm.solve(structure, "static-lp", algorithm="ipm")
                    row["reference_lam"] = ref.multiplier
                    if ref.multiplier is not None and auto.multiplier is not None:
                        row["auto_rel_diff"] = abs(auto.multiplier - ref.multiplier) / max(1.0, abs(ref.multiplier))
                rows.append(row)
                print(row, flush=True)
    columns = [("stones", "stones", "{:,}"), ("irregularity", "irregularity", "{:g}"), ("mu", "mu", "{:g}"),
               ("self_stress", "max -sum n of a self-stress", "{:.3g}"),
               ("compressed_interfaces", "interfaces it compresses", "{:,}"),
               ("block_ipm_status", "block IPM alone", "{}"), ("auto_status", "auto", "{}"),
               ("auto_lam", "auto lam", "{:.6f}"), ("auto_s", "auto s", "{:.1f}")]
    if reference:
        columns += [("reference_lam", "HiGHS ipm lam", "{:.6f}"), ("auto_rel_diff", "auto vs HiGHS", "{:.1e}")]
    print(markdown(rows, columns))
    write_csv(OUT / "self_stress.csv", rows)
    if args.smoke:
        bad = [r for r in rows if r["auto_status"] != "optimal" or not r.get("auto_rel_diff", 1.0) <= 1e-8]
        if bad:
            print(f"smoke: static-lp auto is not optimal or disagrees with HiGHS on {bad}", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""The fixed point on irregular stone walls (issue 42): a damped sequence of interior-point LPs, then Newton on (3).

``fixed-point``'s interior engine (Newton on (3) from Mehrotra's start) stalls on ``stone-wall`` from about 500
stones, with a relative complementarity of 0.01-1, and its central-path continuation does not converge; the simplex
engine's LP steps jump between optimal vertices (``||n - n*|| / ||n||`` about 0.2 step after step).  This study
measures the stage that the interior engine now runs last
(:func:`blockmpec.solvers.engines.interior_fixed_point.sequence_then_newton`), with its knobs exposed:

1. The paper's iteration with each step LP (5) solved by the block IPM (an optimal point near the analytic centre of
   the optimal face, not a vertex), damped: ``n* <- n* + relaxation (n - n*)``, from the associative forces.  Any
   fixed point of this map solves (3), as for the simplex steps.
2. At checkpoints of ``||n - n*|| / ||n||`` (``--stop``, then half of it ..., down to ``--last-checkpoint``),
   Newton on (3) from the last LP's iterate, its slacks recomputed for (3) and ``s, y`` raised by ``sqrt(f mu)``
   for each ``f`` of ``--recentre`` in turn, until one run reaches a solution of (3).

One row per checkpoint and per Newton run: the largest residual of (3) (the verifier's), ``lam``, iterations, seconds.

Usage::

    python studies/lab/fixed_point_irregular.py --stones 1000 --irregularity 0.5
    python studies/lab/fixed_point_irregular.py --stones 60 --stop 1e-3 --recentre 100      # seconds

Writes ``studies/output/fixed_point_irregular/<stones>.csv``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm
from blockmpec.formulations import step_lps
from blockmpec.solvers.engines.highs import static_lp_solution
from blockmpec.solvers.engines.interior_fixed_point import InteriorFixedPoint, recentred_start
from blockmpec.solvers.engines.lp_engine import cold_lp_engine
from blockmpec.solvers.engines.scaling import LoadUnits
from blockmpec.verify import residuals

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from _tables import markdown, write_csv  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "fixed_point_irregular"


def residual_of_3(ops, lp, outcome) -> tuple[float, float]:
    """(largest residual of (3), lam) of an outcome of the step LP (5) read as a point of (3)."""
    solution = static_lp_solution(lp, outcome)
    return max(residuals(ops, solution, associative=False).values()), solution.multiplier


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stones", type=int, default=1000)
    parser.add_argument("--irregularity", type=float, default=0.5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--relaxation", type=float, default=0.3)
    parser.add_argument("--stop", type=float, default=1e-2,
                        help="first checkpoint: try Newton when ||n - n*|| / ||n|| is below it, then at half of it ...")
    parser.add_argument("--last-checkpoint", type=float, default=1e-4, help="stop after this checkpoint")
    parser.add_argument("--max-lps", type=int, default=400)
    parser.add_argument("--aim", type=float, default=0.0,
                        help="weight of the least-compressed aim term kept in every step LP (0: none)")
    parser.add_argument("--lp-tol-factor", type=float, default=0.0,
                        help="solve each step LP to tolerance factor * the last ||n - n*||/||n|| (0: 1e-9)")
    parser.add_argument("--recentre", default="10,30,100", help="comma-separated factors f, tried in this order")
    parser.add_argument("--time-limit", type=float, default=300.0, help="seconds per Newton run")
    args = parser.parse_args(argv)

    height = 0.3 * math.sqrt(args.stones / 2.0)
    wall = bm.cases.stone_wall(width=2 * height, height=height, stone_size=0.3, irregularity=args.irregularity,
                               seed=args.seed)
    ops = bm.assemble(wall)
    lps = step_lps(ops, tie_break=False, associative=True)
    units = LoadUnits.of(ops)
    label = f"stone-wall {wall.n_blocks - 1} stones r={args.irregularity:g}"
    rows = []

    t0 = time.perf_counter()
    associative = cold_lp_engine(lps.associative, "block-ipm", units).solve()
    n_star = np.minimum(static_lp_solution(lps.associative, associative).x[1::3], 0.0)
    sequence = InteriorFixedPoint(lps.step, lps.associative, units, coupling="fixed", tol=1e-9, max_iterations=200,
                                  deadline=math.inf, fold_weight=args.aim)
    sequence.keep_aim = args.aim > 0
    checkpoint, factors, verified = args.stop, [float(f) for f in args.recentre.split(",")], False
    change = math.inf
    for lps_solved in range(1, args.max_lps + 1):
        if args.lp_tol_factor > 0:
            sequence.tol = min(1e-4, max(1e-9, args.lp_tol_factor * change))
        sequence.set_n_star(n_star)
        sequence.best_error, sequence.best_iterate = np.inf, None
        outcome = sequence.solve()
        n = static_lp_solution(lps.step, outcome).x[1::3]
        change = float(np.linalg.norm(n - n_star) / max(np.linalg.norm(n), 1e-300))
        n_star = np.minimum(n_star + args.relaxation * (n - n_star), 0.0)
        if lps_solved % 10 == 0:
            print(f"LP {lps_solved}: ||n - n*||/||n|| = {change:.2e}, {time.perf_counter() - t0:.1f} s", flush=True)
        if change > checkpoint:
            continue
        checkpoint /= 2.0
        worst, lam = residual_of_3(ops, lps.step, outcome)
        rows.append({"structure": label, "stage": f"LP sequence (relaxation {args.relaxation:g})",
                     "n_change": change, "residual": worst, "lam": lam, "iterations": lps_solved,
                     "seconds": time.perf_counter() - t0})
        print(rows[-1], flush=True)
        start = sequence.best_iterate
        for factor in factors:
            newton = InteriorFixedPoint(lps.step, lps.associative, units, coupling="exact", tol=1e-9,
                                        max_iterations=300, deadline=time.perf_counter() + args.time_limit)
            newton.start_iterate = recentred_start(newton, start, factor)
            t1 = time.perf_counter()
            outcome = newton.solve()
            worst, lam = residual_of_3(ops, lps.step, newton.outcome_at(newton.best_iterate))
            verified = outcome.status.is_success and worst <= 1e-6
            rows.append({"structure": label, "stage": f"  Newton on (3), f={factor:g}", "residual": worst, "lam": lam,
                         "iterations": outcome.iterations, "seconds": time.perf_counter() - t1,
                         "status": "verified" if verified else outcome.status.value})
            print(rows[-1], flush=True)
            if verified:
                break
        if verified or checkpoint < args.last_checkpoint:
            break
    rows.append({"structure": label, "stage": "total", "iterations": lps_solved, "seconds": time.perf_counter() - t0,
                 "status": "verified" if verified else "not verified"})

    print(markdown(rows, [("stage", "stage", "{}"), ("n_change", "n change", "{:.1e}"),
                          ("residual", "largest residual of (3)", "{:.1e}"), ("lam", "lam", "{:.6f}"),
                          ("iterations", "iterations", "{}"), ("seconds", "s", "{:.1f}"), ("status", "status", "{}")]))
    write_csv(OUT / f"{args.stones}.csv", rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Closing stages for a stalled interior-point fixed point (issue 14), measured side by side.

The interior engine (:mod:`blockmpec.solvers.engines.interior_fixed_point`) stalls on large
walls.  For one wall this study runs it once (``--weight``: its aim term) and then, from
its best iterate, each closing stage of ``--stages``:

* ``newton``: the semismooth Fischer-Burmeister Newton method of ``mcp-newton``
  (:func:`blockmpec.solvers.engines.newton_system.semismooth_newton`) on (3) from the
  stalled point (``--newton-iterations``, time capped);
* ``cold-steps``: exact fixed-point steps, each the step LP (5) at ``n* = n`` solved cold
  by the block IPM (its analytic-centre answer as the tie-break), until the paper's test
  ``||n - n*|| <= 1e-9 ||n||`` or ``--steps`` LPs;
* ``warm-steps``: the same steps, each started from the previous step's best iterate
  (the first from the stalled iterate, which is an interior point of the LP (5) at its own
  ``n``);
* ``restart``: the exact (Newton on (3)) run again from the stalled iterate with
  ``s, y`` raised by ``sqrt(f mu)`` for each ``f`` of ``--restart-factors``.

Each row: the stage, its CPU seconds, iterations or LPs, the final max relative residual
of (3) by the shared verifier, lam, and whether it verified at 1e-8.

Measured (2 shared cores; verifier at 1e-8; none verified): on the 2,400-block wall
(``--wall 40x60 --steps 4 --newton-iterations 10 --time-limit 60``) the interior run stalls
at a residual of (3) of 1.4e-2 in 4.0 s; cold steps 4 LPs, 25 s, ``||n - n*||/||n||`` still
0.07; warm steps stall at the 2nd LP; restarts 1.1e-3..2.5e-3; Newton 10 iterations, 63 s,
0.44.  On the 10,000-block wall (``--wall 100x100 --weight 0 --steps 2
--restart-factors 1e7 --newton-iterations 5 --time-limit 60``; one cold block-IPM LP:
26.6 s CPU) the run stalls at 0.34 in 23.7 s; the restart 0.27 (33 s); warm steps: 2nd LP
at its 60 s limit (``n`` moved 1.3e-3); cold steps: 2 LPs, 59 s, lam 0.420 then 0.196;
Newton: out of memory in SuperLU on ``J^T J``.  Proximal regularisation, aimed forces paired
with LP duals and arclength continuation: ``studies/lab/fixed_point_continuation.py``.

Usage::

    python studies/lab/fixed_point_polish.py --wall 40x60 [--weight 0.1]
        [--stages newton,cold-steps,warm-steps,restart] [--steps 4] [--time-limit 120]

Prints a markdown table and writes ``studies/output/fixed_point_polish/polish_<wall>.csv``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _tables import markdown, write_csv  # noqa: E402
from _walls import named_wall  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "fixed_point_polish"
VERIFY_TOL = 1e-8


def worst_residual(ops, sol) -> float:
    from blockmpec.verify import residuals

    return max(residuals(ops, sol, associative=False).values())


def row(stage, ops, sol, cpu, count, status) -> dict:
    worst = worst_residual(ops, sol) if sol.multiplier is not None else float("nan")
    return {"stage": stage, "cpu_s": cpu, "count": count, "status": status, "max_residual": worst,
            "multiplier": sol.multiplier, "verified": bool(worst <= VERIFY_TOL)}


def lp_steps(lps, units, first_iterate, n_first, steps: int, warm: bool, time_limit: float):
    """Fixed-point steps n* <- n, each LP (5) by the block IPM (all within ``time_limit`` seconds); returns
    (solution, LPs, status)."""
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.engines.interior_fixed_point import InteriorFixedPoint

    lp = lps.step
    engine = InteriorFixedPoint(lp, lps.associative, units, coupling="fixed", tol=1e-9,
                                deadline=time.perf_counter() + time_limit)
    n_star, iterate, sol, status = np.minimum(n_first, 0.0), first_iterate, None, "step limit"
    for k in range(1, steps + 1):
        engine.set_n_star(n_star)
        engine.start_iterate = iterate if warm else None
        engine.best_error, engine.best_iterate = np.inf, None
        out = engine.solve()  # within the deadline given above
        sol = static_lp_solution(lp, out)
        n = sol.x[1::3]
        change = float(np.linalg.norm(n - n_star)) / max(float(np.linalg.norm(n)), 1e-300)
        print(f"  step {k}: {out.status.value} in {out.iterations} iterations, lam {sol.multiplier:.6g}, "
              f"||n - n*||/||n|| = {change:.2e}", flush=True)
        if not out.status.is_success:
            return sol, k, out.status.value
        if change <= 1e-9:
            return sol, k, "converged"
        n_star, iterate = np.minimum(n, 0.0), engine.best_iterate
    return sol, steps, status


def main(argv: list[str] | None = None) -> list[dict]:
    from blockmpec.deadline import Deadline
    from blockmpec.formulations import compile_mcp, step_lps
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.engines.interior_fixed_point import InteriorFixedPoint
    from blockmpec.solvers.engines.newton_system import MCPSystem, semismooth_newton
    from blockmpec.solvers.engines.scaling import LoadUnits

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--wall", default="40x60", help="CxB: courses x blocks per course")
    parser.add_argument("--weight", type=float, default=0.1, help="aim term of the interior run")
    parser.add_argument("--stages", default="newton,cold-steps,warm-steps,restart")
    parser.add_argument("--steps", type=int, default=4, help="most LPs of the step stages")
    parser.add_argument("--newton-iterations", type=int, default=20)
    parser.add_argument("--restart-factors", default="10,1e3,1e7")
    parser.add_argument("--time-limit", type=float, default=120.0, help="seconds per stage")
    args = parser.parse_args(argv)
    ops = bm.assemble(named_wall(args.wall))
    lps = step_lps(ops, tie_break=False)  # the step LP (5) and the static LP (1): the engine's dual and primal rows
    lp, units = lps.step, LoadUnits.of(ops)
    rows = []
    t0 = time.process_time()
    stalled = InteriorFixedPoint(lp, lps.associative, units, fold_weight=args.weight, tol=1e-9, max_iterations=500,
                                 deadline=time.perf_counter() + args.time_limit)
    out = stalled.solve()
    base = static_lp_solution(lp, out)
    rows.append(row(f"interior (weight {args.weight:g})", ops, base, time.process_time() - t0, out.iterations,
                    out.status.value))
    print(rows[-1], flush=True)
    best = stalled.best_iterate
    for stage in args.stages.split(","):
        t0 = time.process_time()
        if stage == "newton":
            form = compile_mcp(ops)
            t0 = time.process_time()  # compilation is set-up
            try:
                system = MCPSystem(form, base)
                res = semismooth_newton(system, system.pack(base), tol=1e-12, max_iterations=args.newton_iterations,
                                        deadline=Deadline(args.time_limit))
                rows.append(row(stage, ops, res.solution, time.process_time() - t0, res.iterations, res.status.value))
            except MemoryError:
                rows.append({"stage": stage, "cpu_s": time.process_time() - t0, "status": "out of memory (J^T J)"})
        elif stage in ("cold-steps", "warm-steps"):
            sol, count, status = lp_steps(lps, units, best, stalled.normal_forces(best), args.steps,
                                          stage == "warm-steps", args.time_limit)
            rows.append(row(stage, ops, sol, time.process_time() - t0, count, status))
        elif stage == "restart":
            for factor in (float(f) for f in args.restart_factors.split(",")):
                t0 = time.process_time()
                start = best.copy()
                shift = np.sqrt(factor * float(start.s @ start.y) / start.s.size)
                start.s += shift
                start.y += shift
                engine = InteriorFixedPoint(lp, lps.associative, units, tol=1e-9, max_iterations=500,
                                            deadline=time.perf_counter() + args.time_limit)
                engine.start_iterate = start
                again = engine.solve()
                rows.append(row(f"restart x{factor:g}", ops, static_lp_solution(lp, again),
                                time.process_time() - t0, again.iterations, again.status.value))
                print(rows[-1], flush=True)
            continue
        else:
            raise SystemExit(f"unknown stage {stage!r}")
        print(rows[-1], flush=True)
    columns = [("stage", "stage", "{}"), ("cpu_s", "CPU s", "{:.3g}"), ("count", "iterations / LPs", "{}"),
               ("status", "status", "{}"), ("max_residual", "max residual of (3)", "{:.1e}"),
               ("multiplier", "lam", "{:.5g}"), ("verified", "verified 1e-8", "{}")]
    print(markdown(rows, columns))
    print(f"wrote {write_csv(OUT / f'polish_{args.wall}.csv', rows)}")
    return rows


if __name__ == "__main__":
    main()

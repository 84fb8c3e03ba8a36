r"""Why the interior-point fixed point stalls on large walls, and three remedies measured (issue 14).

The interior engine (:mod:`blockmpec.solvers.engines.interior_fixed_point`) runs Mehrotra's
method on the MCP (3) written as the step LP (5) with ``n* = n``; on walls of 2,400 and
10,000 blocks it stalls (``NUMERICAL``).  For one wall this study runs, side by side:

* ``interior``: the engine's run as shipped (aim weight ``--weight``), its CPU seconds and the
  shared verifier's worst residual of (3);
* ``proximal``: the same run with primal-dual proximal terms that make every Newton step
  monotone (:class:`ProximalInteriorFixedPoint`): ``rho_k (n_k - n_k^c)`` in the dual row of
  each normal force and ``-delta_k (y_r - y_r^c)`` in its two friction rows, with
  ``rho_k delta_k = (p |a_k| / 2)^2`` (``a_k``: the two entries of ``G_phi - G_psi`` of interface
  ``k``, ``p >= 1`` monotone), the centre moved to the iterate at every iteration (``every``:
  a regularised Newton method) or when the proximal subproblem's residuals fall below a tenth
  of those of (3) (``converged``: an inexact proximal-point method); ``--proximal`` lists
  ``p:balance:recentre`` triples (``balance = rho_k / delta_k`` up to the common size);
* ``aimed``: the aim term kept to the end (``keep_aim``), then the step LP (5) at the aimed
  run's own normal forces solved cold by the block IPM, and the aimed forces paired with that
  LP's duals (any optimal primal and dual of one LP are complementary: a solution of (3) if
  the aimed forces are optimal for their own LP);
* ``arclength``: the interior run stopped after ``--start-iteration`` iterations (before its
  steps shorten) or at its stalled best iterate (``best``), then
  :func:`blockmpec.solvers.engines.interior_fixed_point.continue_central_path`: pseudo-arclength
  continuation of the weighted central path through that point (``s o y = mu w``, the residuals
  of the linear rows scaled by ``mu / mu_0``) with a tangent predictor and a bordered Newton
  corrector (two solves with the same factors), for ``--arc-steps`` steps or ``--time-limit``
  seconds, until the residuals of (3) are at most 1e-9.  ``fixed-point`` with
  ``engine="interior"`` now runs it from the stalled iterate itself.

Measured (2 shared cores; one run of the defaults, ``--wall 40x60``: 2,420 free blocks, one
cold block-IPM LP ~3 s CPU; verified = worst residual of (3) at most 1e-8):

| stage | CPU s | iterations / steps | status | worst residual | value | lam |
|---|---:|---:|---|---|---:|---:|
| interior (aim 0) | 5.78 | 51 | numerical | friction_complementarity | 1.3e-03 | 0.41858 |
| proximal p=1 balance=1 every | 8.18 | 79 | numerical | friction_complementarity | 1.5e+03 | 0.00027 |
| proximal p=1 balance=30 every | 2.62 | 23 | numerical | compatibility | 9.7e-01 | 0.0256 |
| proximal p=1 balance=0.03 every | 4.62 | 44 | numerical | friction_complementarity | 5.3e+05 | -0.0001 |
| proximal p=1 balance=1 converged | 1.77 | 14 | numerical | friction_complementarity | 2.9e+05 | 7e-07 |
| aimed 0.1 (aimed problem) | 4.13 | 36 | numerical | compatibility | 7.2e-01 | 0.41696 |
| aimed 0.1: forces + LP duals | 7.43 | 57 | paired | unilateral_complementarity | 7.4e-04 | 0.41696 |
| aimed 0.001: forces + LP duals | 9.13 | 69 | paired | unilateral_complementarity | 5.7e-04 | 0.41693 |
| arclength from iteration 5 (corrector 0.3) | 63.5 | 150 (170 factorisations) | mu 5.0e-08 | friction_complementarity | 7.3e-04 | 0.41868 |

* ``interior``: its steps are short (0.2..0.6) from ``mu`` ~ 4e-4 on (iteration 4), and it
  stalls at ``mu`` ~ 8.6e-8 with ``s o y`` between 0.035 and 2,160 ``mu``; from there even pure
  centring (``sigma = 1``, 60 damped Newton steps) makes the smallest product fall from 0.13 to
  3e-7 ``mu``: the iterate has left the path.
* ``proximal``: none converges; lam drifts to ~0.  The proximal terms are exact (a full step
  zeroes the regularised linear residuals to 1e-12), so the method, not the algebra, fails.
  On an 8x10 wall (80 blocks, where the plain run converges) every variant fails as well.
* ``aimed``: the aimed forces are not optimal for their own LP (5) here (the LP at them: lam
  0.418 and 0.41782), so pairing gives no solution of (3); on the 1,010-block wall every aimed
  run is ``OPTIMAL`` in 22 iterations with lam 0.449329 for weights 0.1, 0.01 and 0.001 but the
  LP at its forces reaches 0.449799 (paired: friction complementarity 4.7e-4).  It works on the
  8x10 wall: verified at 7e-10, lam 0.54245 against the plain run's 0.55122.
* ``arclength``: the weighted path continues well below the stall with no turning point (the
  relative ``dmu/ds`` stays between -6e-3 and -1e-3).  The steps are limited by the path's
  curvature (friction rows switching between stick and slip one group after another): about
  40 steps per decade of ``mu`` and slowing, against Mehrotra's 4 decades in its first 5
  iterations.  With a corrector to 1e-3 of the weighted products (``--corrector-tol 1e-3``):
  ``mu`` 2.0e-8 after 230 steps, 524 factorisations, 177 s CPU.  On the 8x10 wall it converges:
  verified at 7e-14 in 30 steps (31 factorisations).  Run on (``--arc-steps 2000 --time-limit
  500``), the groups of switches end near ``mu`` ~ 2e-9 and the path then goes straight to
  ``mu = 0``: verified at 2.3e-14, lam 0.41935, after 330 steps (184 s CPU in all).  From the
  stalled iterate (``--start-iteration best``): verified at 3.2e-10, lam 0.41939, after 155 steps
  (74 s CPU in all, ~20x one cold LP); ``fixed-point`` now does this by itself.
* ``arclength`` on the 10,050-block wall (``--wall 100x100 --start-iteration best``): the path
  through the stalled point (``mu`` 5.6e-6, relative complementarity 0.5) turns after ~30 steps
  (``dmu/ds`` changes sign) and runs back to ``mu`` ~ 4e9 within 110 steps (170 s CPU): no
  solution of (3) on it.  From the interior run's first short step (``--start-iteration auto``:
  iteration 5, ``mu`` 1.1e-4): 644 steps (700 factorisations, 786 s CPU, ~19x one cold LP)
  bring ``mu`` only to 7.3e-7 (worst residual of (3) 4.5e-2, lam 0.366): still among the
  stick/slip switches when the time limit (1,100 s) ran out.

Usage::

    python studies/lab/fixed_point_continuation.py --wall 40x60 [--stages interior,proximal,aimed,arclength]
        [--proximal "1:1:every;1:30:every;1:1:converged"] [--aim-weights 0.1,0.001]
        [--start-iteration 5] [--arc-steps 150] [--corrector-tol 0.3] [--time-limit 300]

Prints a markdown table and writes ``studies/output/fixed_point_continuation/continuation_<wall>.csv``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm
from blockmpec.solvers.engines.interior_fixed_point import InteriorFixedPoint, continue_central_path
from blockmpec.solvers.linalg.block_ipm import BlockIPM, IPMIterate

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _tables import markdown, write_csv  # noqa: E402
from _walls import named_wall  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "fixed_point_continuation"
RECENTRES = ("every", "converged")


class ProximalInteriorFixedPoint(InteriorFixedPoint):
    r"""Newton on (3) with proximal terms that make each linearised step monotone.

    The linearisation of (3) in ``(v, w, y)`` has the symmetric part
    ``-(G_phi - G_psi)^T / 2`` between ``v`` and ``y``: ``z^T J z = -y^T (G_phi - G_psi) v``,
    which per interface is ``-n_k (a_k^+ y_k^+ + a_k^- y_k^-)``.  Adding ``rho_k`` to the
    dual row of ``n_k`` and ``delta_k`` to the primal friction rows (``G v + s - delta (y - y^c)
    = h``) gives ``rho_k n_k^2 + delta_k |y_k|^2 - n_k a_k . y_k >= 0`` when
    ``rho_k delta_k >= |a_k|^2 / 4``.  In the block systems this is ``rho`` on the top-left
    diagonal and ``-(I + delta D)`` on the bottom-right one (``[[rho, B_psi^T], [B_phi, -I]]``
    scaled as in :meth:`BlockIPM.block_systems`); ``ds = -r_h - G dv + delta dy``.  The
    whole-system refinement of :class:`BlockIPM` does not know these terms, so it is off
    (``final_sweeps`` 0); the block equations hold exactly and the reduced refinement
    corrects the equality rows.  The stopping test reads the residuals of (3) itself.
    """

    def __init__(self, lp, coulomb_lp, units, proximal: float = 1.0, balance: float = 1.0, recentre: str = "every",
                 recentre_ratio: float = 0.1, **options) -> None:
        super().__init__(lp, coulomb_lp, units, **options)
        if recentre not in RECENTRES:
            raise ValueError(f"proximal fixed point: unknown recentre {recentre!r}; use one of {', '.join(RECENTRES)}")
        self.recentre, self.recentre_ratio, self.recentres = recentre, float(recentre_ratio), 0
        rows = self.friction_position.reshape(-1, 2)
        a = self.in_scale[rows] * self.cohesion_factor[:, None] * self.column_scale[self.normal_columns][:, None]
        size = float(proximal) * np.sqrt((a ** 2).sum(axis=1)) / 2
        self.prox_v = np.zeros(self.c.size)
        self.prox_v[self.normal_columns] = size * balance
        self.prox_y = np.zeros(self.h.size)
        self.prox_y[rows] = (size / balance)[:, None]
        self.centre: tuple[np.ndarray, np.ndarray] | None = None
        self.settings(final_sweeps=0)

    def block_systems(self, it: IPMIterate):
        M, sqrt_d = super().block_systems(it)
        k, r = self.k, np.arange(self.rows_per_block)
        M[:, np.arange(k), np.arange(k)] += self.prox_v[self.block_columns]
        M[:, k + r, k + r] -= self.prox_y[self.block_rows] * sqrt_d ** 2
        return M, sqrt_d

    def direction(self, it, factors, r_b, r_h, r_c, r_mu, refinements=None, tolerance=0.0):
        dv, ds, dw, dy = super().direction(it, factors, r_b, r_h, r_c, r_mu, refinements, tolerance)
        return dv, ds + self.prox_y * dy, dw, dy

    def residuals(self, it: IPMIterate):
        r_b, r_h, r_c = super().residuals(it)
        if self.centre is not None:
            v_c, y_c = self.centre
            r_c = r_c + self.prox_v * (it.v - v_c)
            r_h = r_h - self.prox_y * (it.y - y_c)
        return r_b, r_h, r_c

    def measures(self, it: IPMIterate, residuals=None):
        """Relative (primal, dual, complementarity) of (3) itself, without the proximal terms."""
        return super().measures(it, BlockIPM.residuals(self, it))

    def before_iteration(self, it: IPMIterate) -> None:
        if self.centre is None or self.recentre == "every":
            self.centre = (it.v.copy(), it.y.copy())
        else:
            subproblem = max(BlockIPM.measures(self, it, self.residuals(it)))
            if subproblem <= self.recentre_ratio * max(self.measures(it)):
                self.centre = (it.v.copy(), it.y.copy())
                self.recentres += 1
        super().before_iteration(it)


def worst_residual(ops, sol) -> tuple[str, float]:
    from blockmpec.verify import residuals

    values = residuals(ops, sol, associative=False)
    name = max(values, key=values.get)
    return name, float(values[name])


def result_row(stage, ops, sol, cpu, count, status, **extra) -> dict:
    name, worst = worst_residual(ops, sol) if sol.multiplier is not None else ("", float("nan"))
    return {"stage": stage, "cpu_s": cpu, "count": count, "status": status, "worst": name, "max_residual": worst,
            "multiplier": sol.multiplier, "verified": bool(worst <= 1e-8), **extra}


def main(argv: list[str] | None = None) -> list[dict]:
    from blockmpec.deadline import Deadline
    from blockmpec.formulations import step_lps
    from blockmpec.result import Solution
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.engines.scaling import LoadUnits

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--wall", default="40x60", help="CxB: courses x blocks per course")
    parser.add_argument("--stages", default="interior,proximal,aimed,arclength")
    parser.add_argument("--weight", type=float, default=0.0, help="aim weight of the interior stage")
    parser.add_argument("--proximal", default="1:1:every;1:30:every;1:0.03:every;1:1:converged",
                        help="';'-separated p:balance:recentre")
    parser.add_argument("--aim-weights", default="0.1,0.001")
    parser.add_argument("--start-iteration", default="5",
                        help="iterations of the interior run before the continuation; 'auto': up to its first "
                             "step shorter than 0.5; 'best': its best (stalled) iterate")
    parser.add_argument("--arc-steps", type=int, default=150)
    parser.add_argument("--corrector-tol", type=float, default=0.3)
    parser.add_argument("--time-limit", type=float, default=300.0,
                        help="seconds per stage (the continuation: wall clock)")
    args = parser.parse_args(argv)
    ops = bm.assemble(named_wall(args.wall))
    lps = step_lps(ops, tie_break=False)  # the step LP (5) and the static LP (1): the engine's dual and primal rows
    lp, units = lps.step, LoadUnits.of(ops)
    print(f"{args.wall}: {ops.n_free_blocks} free blocks", flush=True)
    rows = []

    def interior(cls=InteriorFixedPoint, **options):
        """The engine on this wall, ``--time-limit`` seconds from now (each stage its own)."""
        return cls(lp, lps.associative, units, tol=1e-9, deadline=time.perf_counter() + args.time_limit, **options)

    def add(row):
        rows.append(row)
        print({k: v for k, v in row.items()}, flush=True)

    for stage in args.stages.split(","):
        if stage == "interior":
            t0 = time.process_time()
            engine = interior(fold_weight=args.weight)
            out = engine.solve()
            add(result_row(f"interior (aim {args.weight:g})", ops, static_lp_solution(lp, out),
                           time.process_time() - t0, out.iterations, out.status.value))
        elif stage == "proximal":
            for spec in args.proximal.split(";"):
                p, balance, recentre = spec.split(":")
                t0 = time.process_time()
                engine = interior(ProximalInteriorFixedPoint, proximal=float(p), balance=float(balance),
                                  recentre=recentre)
                out = engine.solve()
                add(result_row(f"proximal p={p} balance={balance} {recentre}", ops, static_lp_solution(lp, out),
                               time.process_time() - t0, out.iterations, out.status.value,
                               recentres=engine.recentres))
        elif stage == "aimed":
            for weight in (float(w) for w in args.aim_weights.split(",")):
                t0 = time.process_time()
                aimed = interior(fold_weight=weight, fold_off=0.0, fold_knee=1e-300)
                aimed.keep_aim = True
                out = aimed.solve()
                sol = static_lp_solution(lp, out)
                add(result_row(f"aimed {weight:g} (aimed problem)", ops, sol, time.process_time() - t0,
                               out.iterations, out.status.value))
                step = interior(coupling="fixed")
                step.set_n_star(np.minimum(sol.x[1::3], 0.0))
                lp_out = step.solve()
                lp_sol = static_lp_solution(lp, lp_out)
                add(result_row(f"aimed {weight:g}: LP (5) at its forces", ops, lp_sol, time.process_time() - t0,
                               lp_out.iterations, lp_out.status.value))
                paired = Solution(multiplier=sol.multiplier, x=sol.x, u=lp_sol.u, z_u=lp_sol.z_u, z_f=lp_sol.z_f)
                add(result_row(f"aimed {weight:g}: forces + LP duals", ops, paired, time.process_time() - t0,
                               out.iterations + lp_out.iterations, "paired"))
        elif stage == "arclength":
            t0 = time.process_time()
            first = args.start_iteration
            if first in ("auto", "best"):
                engine = interior()
                engine.solve()
                short = [r["k"] for r in engine.trace if min(r["step_primal"], r["step_dual"]) < 0.5]
                first = "best" if first == "best" or not short else short[0]
            if first != "best":
                engine = interior(max_iterations=int(first))
                engine.solve()
            start = engine.best_iterate
            t1 = time.perf_counter()

            def report(step, mu, primal, dual, complementarity, multiplier, factorisations):
                if step % 10 == 0:
                    print(f"  arclength step {step}: mu {mu:.3e}, gap {complementarity:.2e}, primal {primal:.1e}, "
                          f"dual {dual:.1e}, lam {multiplier:.6g}, {factorisations} factorisations, "
                          f"{time.perf_counter() - t1:.1f} s", flush=True)

            end, facts = continue_central_path(engine, start, tol=1e-9, deadline=Deadline(args.time_limit),
                                               max_steps=args.arc_steps, corrector_tol=args.corrector_tol,
                                               record=report)
            add(result_row(f"arclength from iteration {first} (corrector {args.corrector_tol:g})",
                           ops, static_lp_solution(lp, engine.outcome_at(end)), time.process_time() - t0, facts["steps"],
                           f"mu {facts['mu']:.2e}", factorisations=facts["factorisations"],
                           gap=engine.measures(end)[2]))
        else:
            raise SystemExit(f"unknown stage {stage!r}")
    columns = [("stage", "stage", "{}"), ("cpu_s", "CPU s", "{:.3g}"), ("count", "iterations / steps", "{}"),
               ("status", "status", "{}"), ("worst", "worst residual", "{}"), ("max_residual", "value", "{:.1e}"),
               ("multiplier", "lam", "{:.5g}"), ("verified", "verified 1e-8", "{}")]
    print(markdown(rows, columns))
    print(f"wrote {write_csv(OUT / f'continuation_{args.wall}.csv', rows)}")
    return rows


if __name__ == "__main__":
    main()

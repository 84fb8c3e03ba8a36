r"""Routes to a fixed point within 3x one cold LP at 10,000 blocks (issue 14), measured one by one.

The interior engine (:mod:`blockmpec.solvers.engines.interior_fixed_point`, Newton on the MCP (3)
inside one interior-point run) costs about one cold block-IPM LP at 1,000 blocks but stalls at
2,400 and 10,000 blocks.  This study measures the routes that replace or repair it.  Each route
runs on one wall (``--wall CxB``) and prints one row per run; rows go to
``studies/output/fixed_point_routes/<route>_<wall>.csv``.  ``--cold`` first times one cold
``static-lp`` (the block IPM at these sizes), the unit of the target.

Routes (subcommands):

* ``steps``: the paper's fixed point on ``n*``.  Each step LP (5) at ``n*`` is solved by the block
  IPM (:class:`InteriorFixedPoint` with ``coupling="fixed"``: an LP, symmetric ``K``), started from
  the previous step's last iterate (:func:`warm_start`: slacks of the new rows, ``s`` and ``y``
  floored at ``sqrt(mu_target)``), the least-compressed rule folded into the objective with weight
  ``--fold``, ``n*`` updated plainly, damped (``--relax``) or by Anderson mixing (``--accel``).  The
  test is the paper's ``||n - n*|| <= tol ||n||``; with a fold, the last forces are paired with the
  duals of the plain LP (5) at the last ``n*`` (both optimal for that LP if the fold picked an LP optimum).
* ``path``: Newton on (3) by infeasible path following: Mehrotra's sigma and corrector, one step length,
  backtracked until ``s_i y_i >= gamma mu`` (the wide neighbourhood of the central path).
* ``gap``: Newton on (3) at a smaller dilatancy gap ``tan(phi) - tan(psi)``: ``--fractions`` of the
  gap, each run cold (``sweep``) or the stages in order, each started from the previous stage's answer
  with ``s, y`` floored at ``sqrt(mu_target)`` (``homotopy``; the dual rows' slope is moved in place,
  :func:`set_dual_slope`).
* ``trust``: one run of the LP (5) with ``n*`` moved inside it (``n* += min(1, radius / ||n - n*||) (n - n*)``)
  at iterates whose products are at least ``centrality mu``; its stopping test includes ``||n - n*||/||n||``.
* ``mixed``: Newton on a fraction ``theta`` of the gap, the rest of the cohesion lagged (``n* := n``
  before every iteration): between the interior engine (``theta = 1``) and its lagged coupling (0).
* ``active-set``: from the interior engine's answer, a primal-dual active-set method (semismooth
  Newton on ``min(s, y) = 0``): each step one factorisation of ``K`` at ``(s, y) = (delta, 1)`` on the
  active rows and ``(1, delta)`` on the others.
* ``pieces``: from the interior engine's stalled point (aim ``--fold``, no continuation) straight to ``nlp``'s
  split piece LPs, which turn any solution of (3) into a certified local minimum of (4) (they solve the
  2,032-block wall from the fixed point's answer): can they round a stalled point onto a solution of (3)?
* ``ties``: the interior engine's aimed run (no continuation) with other aim weights (``--aims``), or on the wall
  with every interface's friction lowered at random by up to a fraction ``--eps``: is the stall the aim's, or the
  running bond's ties between equal interfaces?
* ``hybrid``: Newton on (3) with the dilatancy gap kept only on a set ``S`` of interfaces and associative flow
  elsewhere (:func:`route_hybrid`): ``S`` starts as the interfaces that slide in the associative LP's solution and
  grows by those that slide outside it, until none does.  Is the stall the size of the non-monotone part?

Measured (2 shared cores, CPU seconds; one cold block-IPM LP: 1,010 blocks 0.9 s / 21 iterations,
10,050 blocks 24.7 s / 53 iterations; budget of the target: ~3x those iterations):

| route | wall (blocks) | result |
|---|---|---|
| ``steps``, no fold | 20x50 (1,010) | 15 LPs, 201 iterations: ``n`` wanders (``||n - n*||/||n||`` 1e-2, lam 0.4521..0.4526) |
| ``steps``, fold 1e-4, ``mu_target`` 1e-4 / 1e-7 | 20x50 | 25 LPs, 262 / 254 iterations (5-7 per warm LP): ``||n - n*||/||n||`` still 5e-4 / 3e-5, linear rate ~0.8 |
| ``steps``, + Anderson (5) or relaxation 0.5 | 20x50 | 40 LPs, 404 / 437 iterations: 5e-5 / 5e-4 |
| ``steps``, fold 1e-4, ``mu_target`` 1e-7 | 100x100 (10,050) | 3 LPs, 134 iterations, 61.9 s (2.8x the cold LP's 22.2 s in the same run): the 2nd LP (``n`` moved 0.88) takes 107 warm iterations (``ACCEPTABLE``), the 3rd ends ``NUMERICAL`` |
| ``path``, gamma 1e-3, sigma_min 0.1 | 20x50 | verified in 32 iterations (lam 0.45205), like Mehrotra's 20 |
| ``path`` | 40x60 (2,420) | stalls at mu ~1e-7 as Mehrotra does: 150 iterations, sigma 0.3..0.98, steps 1e-3..1, centrality kept (min product 1e-3..0.4 mu) |
| ``gap`` sweep, cold | 40x60 | converges for ``tan(psi)`` 0.6, 0.5, 0.4, 0.2 (30-48 iterations); stalls at 0.1, 0.05, 0 (1.3e-3) |
| ``gap`` sweep, cold | 100x100 (10,050) | converges for 0.6, 0.5, 0.45 (50, 60, 88 iterations); stalls at 0.3 (1.1e-3) and 0.2 |
| ``gap`` homotopy 0.3 -> 0 (fractions of the gap) | 40x60 | first stage 65 iterations, the next stalls (3.0e-3; via 0.15: 5e-5 then 2.8e-3) |
| ``gap`` homotopy 0.77 -> 0.46 -> 0 | 100x100 | 63 iterations, then stalls at 4.2e-3 (56 iterations) |
| ``trust``, radius 0.1 / 0.02 | 20x50 | ``NUMERICAL`` (friction complementarity 0.38 / 0.28), where Newton on (3) converges in 20 |
| ``mixed``, theta 0.7 / 0.4 | 20x50 | ``NUMERICAL``: stalls at 2.7e-5 / 1.7e-4 (27 / 49 iterations); theta 1 converges in 18 |
| ``active-set`` | 20x50 | diverges from the converged interior answer (1,074 of 11,760 rows switch at once; the piece systems are singular: degenerate forces) |
| ``pieces``, aim 0.1 | 40x60 | the stalled point (49 iterations; worst residual of (3) 1.3e-2) gives mechanisms (supports of 1,906 and 120 pairs) whose static pieces the block IPM ends ``NUMERICAL`` (18 s); with ``--static-engine dual-simplex --time-limit 1500`` HiGHS proves the first one infeasible and the second runs out of time (1,480 s CPU) |
| ``pieces``, aim 0.1 | 70x70 (4,935) | stalled point 0.32 from (3) (34 iterations); three piece LPs, no solution of (3) within the 300 s limit |
| ``ties``, aims 0, 0.01, 0.03, 0.3, 1, 3 | 40x60 | every run ``NUMERICAL``: 46-85 iterations, worst residual of (3) 7e-5 to 1.7e-2 |
| ``ties``, friction lowered by up to 1e-6 / 1e-4 / 1e-2, aim 0.1 | 40x60 | ``NUMERICAL``: 45 / 46 / 32 iterations, 4.7e-3 / 1.1e-2 / 7.5e-3 (unperturbed: 49, 1.3e-2) |
| ``hybrid`` (``--cold``) | 20x50 | verified (6.2e-12, lam 0.452074) in two cold rounds, ``S`` 209 then 218 of 2,940 interfaces (20 + 19 iterations); with the associative LP 1.55 s, 3.3x the cold LP's 0.47 s (the default interior engine: 1.4x) |
| ``hybrid`` (``--cold``) | 40x60 | ``S`` of 1,309 of 7,120 interfaces: the first round stalls (``NUMERICAL``, 67 iterations) |
| ``hybrid``, ``--share 0.1`` | 40x60 | the first round (``S`` 290) converges in 68 iterations, but 1,162 interfaces slide outside ``S``; the second (``S`` 1,452) stalls |
| ``hybrid``, ``--share 0.1 --outside 0.1 --continued --time-limit 600`` | 40x60 | the second round (``S`` 346) continued from the first's answer: 2,593 steps (7,241 factorisations, 646 s CPU), ends at mu 2.7e-7, no solution |
| ``hybrid``, ``--share 0.1`` (``--cold``) | 100x100 | ``S`` of 1,971 of 29,850 interfaces: the first round stalls (``NUMERICAL``, 51 iterations, 18.1 s against the cold LP's 10.8 s) |

The classic fixed point's steps are cheap once warm (5-7 iterations of a symmetric ``K``), but the
analytic-centre answers of the step LPs converge only linearly, and slowly, even with the fold
(no route there met ``||n - n*|| <= 1e-9 ||n||``); at 10,050 blocks three LPs already cost 2.8x one
cold LP, where the simplex engine's fixed point takes tens of steps.  Every route on
(3) itself stalls where the gap is large (keeping the gap only where the mechanism slides, ``hybrid``,
converges at 2,420 blocks with 290 such interfaces but not once the set holds those that then slide outside
it, 346 to 1,452): the cold Newton run converges at 10,050 blocks only up to a gap of ~0.2 (of 0.65), and
from a solution at a smaller gap the next stage stalls, so the difficulty is the problem at ``psi = 0``, not
the path taken to it.

Usage::

    python studies/lab/fixed_point_routes.py steps --wall 20x50 --fold 1e-4 --mu-target 1e-7 [--accel anderson]
    python studies/lab/fixed_point_routes.py path --wall 40x60
    python studies/lab/fixed_point_routes.py gap --wall 100x100 --fractions 0.92,0.77,0.69,0.46 --mode sweep
    python studies/lab/fixed_point_routes.py gap --wall 100x100 --fractions 0.77,0.46,0 --mode homotopy
    python studies/lab/fixed_point_routes.py trust --wall 20x50 --radius 0.1
    python studies/lab/fixed_point_routes.py active-set --wall 20x50
    python studies/lab/fixed_point_routes.py pieces --wall 40x60 --fold 0.1 [--static-engine dual-simplex]
    python studies/lab/fixed_point_routes.py ties --wall 40x60 --fold 0.1 --eps 0,1e-6,1e-4,1e-2
    python studies/lab/fixed_point_routes.py ties --wall 40x60 --eps 0 --aims 0,0.01,0.03,0.3,1,3
    python studies/lab/fixed_point_routes.py hybrid --wall 40x60 --share 0.1 [--outside 0.1 --continued]
    python studies/lab/fixed_point_routes.py smoke  # the smallest ties and hybrid runs, checked (CI)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm
from blockmpec.solvers.engines.piece_lp import STATIC_ENGINES

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _tables import markdown, write_csv  # noqa: E402
from _walls import lowered_friction, named_wall  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "fixed_point_routes"
VERIFY_TOL = 1e-8


def worst(ops, sol) -> tuple[str, float]:
    """The largest relative residual of (3) (shared verifier) and its name."""
    from blockmpec.verify import residuals

    if sol.multiplier is None or not np.isfinite(sol.multiplier):
        return "none", float("nan")
    r = residuals(ops, sol, associative=False)
    name = max(r, key=r.get)
    return name, float(r[name])


def result_row(route: str, setting: str, ops, sol, iterations: int, cpu: float, status: str, **more) -> dict:
    name, value = worst(ops, sol)
    row = {"route": route, "setting": setting, "blocks": ops.n_free_blocks, "iterations": iterations,
           "cpu_s": cpu, "status": status, "multiplier": sol.multiplier, "worst_residual": name,
           "worst_value": value, "verified": bool(value <= VERIFY_TOL), **more}
    print(row, flush=True)
    return row


def warm_start(engine, z, mu_target: float):
    """The previous LP's last iterate moved to the engine's LP: ``s`` the new rows' slack, ``s, y`` floored at
    ``sqrt(mu_target)`` (so the products are at least ``mu_target``)."""
    z = z.copy()
    floor = np.sqrt(mu_target)
    z.s = np.maximum(engine.h - engine.G @ z.v, floor)
    z.y = np.maximum(z.y, floor)
    return z


def set_dual_slope(engine, slope, base_slope) -> None:
    """Move the dual rows' friction slope of an exact-coupling engine built at ``base_slope`` to ``slope``
    (the primal rows keep ``tan(phi)``)."""
    import scipy.sparse as sp

    rows = engine.friction_position
    cols = np.repeat(engine.normal_columns, 2)
    if getattr(engine, "gap_dual_base", None) is None:  # the engine's own dual rows, kept by this study
        engine.gap_dual_base = engine.G_dual
    delta = np.broadcast_to(np.asarray(slope, float) - base_slope, (engine.normal_columns.size,))
    extra = sp.csr_array((engine.in_scale[rows] * np.repeat(delta, 2) * engine.column_scale[cols], (rows, cols)),
                         shape=engine.G.shape)
    engine.G_dual = (engine.gap_dual_base + extra).tocsr()
    engine.g_dual_blocks = engine.dense_blocks(engine.G_dual)


def step_lp(ops):
    """The compiled step LP (5) of ``ops`` (``tan(psi)`` rows, ``n* = 0``)."""
    from blockmpec.formulations import step_lps

    return step_lps(ops, tie_break=False, associative=False).step


def interior(ops, cls=None, time_limit: float | None = None, **options):
    """The interior fixed point (or its subclass ``cls``) on the step LP (5) of ``ops``, with the static LP (1) as its
    primal rows, in load units, ``time_limit`` seconds from now (None: no limit)."""
    from blockmpec.formulations import step_lps
    from blockmpec.solvers.engines.interior_fixed_point import InteriorFixedPoint
    from blockmpec.solvers.engines.scaling import LoadUnits

    lps = step_lps(ops, tie_break=False)
    deadline = np.inf if time_limit is None else time.perf_counter() + time_limit
    return (cls or InteriorFixedPoint)(lps.step, lps.associative, LoadUnits.of(ops), deadline=deadline, **options)


def stalled_point(lp, ops, aim: float, args):
    """The interior engine's run on ``ops``'s step LP ``lp`` (aim ``aim``, no continuation, ``--iterations``,
    ``--time-limit``) and its best iterate as a solution, the aim switched off: ``(outcome, solution)``."""
    from blockmpec.solvers.engines.highs import static_lp_solution

    engine = interior(ops, fold_weight=aim, tol=1e-9, max_iterations=args.iterations, time_limit=args.time_limit)
    out = engine.solve()
    engine.set_fold(0.0)
    return out, static_lp_solution(lp, engine.outcome_at(engine.best_iterate))


# ---------------------------------------------------------------------------------------------- routes
def route_steps(ops, args) -> list[dict]:
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.engines.lp_sequence import Anderson

    lp = step_lp(ops)
    t0 = time.process_time()
    engine = interior(ops, coupling="fixed", tol=1e-9, max_iterations=200, time_limit=args.time_limit)
    engine.set_fold(args.fold)
    mixer = Anderson(args.memory, args.relax) if args.accel == "anderson" else None
    n_star, iterate, total, sol, change, status = np.zeros(ops.n_interfaces), None, 0, None, np.inf, "step limit"
    for k in range(1, args.steps + 1):
        engine.set_n_star(n_star)
        engine.start_iterate = None if iterate is None else warm_start(engine, iterate, args.mu_target)
        engine.best_error, engine.best_iterate, engine.mu0 = np.inf, None, None
        out = engine.solve()
        total += out.iterations
        sol = static_lp_solution(lp, out)
        n = sol.x[1::3]
        change = float(np.linalg.norm(n - n_star)) / max(float(np.linalg.norm(n)), 1e-300)
        print(f"  step {k}: {out.status.value} {out.iterations} it (total {total}), lam {sol.multiplier:.8f}, "
              f"||n - n*||/||n|| {change:.2e}, cpu {time.process_time() - t0:.1f}", flush=True)
        if not out.status.is_success:
            status = out.status.value
            break
        iterate = engine.best_iterate if engine.best_iterate is not None else iterate
        if change <= args.tol:
            status = "converged"
            break
        if mixer is not None:
            n_star = np.minimum(mixer.update(n_star, np.minimum(n, 0.0)), 0.0)
        else:
            n_star = np.minimum(n_star + args.relax * (n - n_star), 0.0)
    if args.fold > 0 and sol is not None and iterate is not None:
        # duals of the plain LP (5) at the last n*, paired with the folded forces
        engine.set_fold(0.0)
        engine.set_n_star(n_star)
        engine.start_iterate = warm_start(engine, iterate, args.mu_target)
        engine.best_error, engine.best_iterate = np.inf, None
        out = engine.solve()
        total += out.iterations
        plain = static_lp_solution(lp, out)
        sol = type(sol)(multiplier=sol.multiplier, x=sol.x, u=plain.u, z_u=plain.z_u, z_f=plain.z_f)
    setting = f"fold {args.fold:g}, mu_target {args.mu_target:g}, {args.accel}, relax {args.relax:g}"
    return [result_row("steps", setting, ops, sol, total, time.process_time() - t0, status, lps=k,
                       n_change=change)]


def route_path(ops, args) -> list[dict]:
    """Infeasible path following on (3) in the neighbourhood ``s_i y_i >= gamma mu``."""
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.linalg.block_ipm import IPMIterate, single_blas_thread

    lp = step_lp(ops)
    t0 = time.process_time()
    engine = interior(ops, tol=1e-9)
    z = engine.initial_point()
    p = z.s.size
    k = 0
    with single_blas_thread():
        for k in range(args.iterations):
            r_b, r_h, r_c = engine.residuals(z)
            primal, dual, comp = engine.measures(z, (r_b, r_h, r_c))
            mu = float(z.s @ z.y) / p
            if max(primal, dual, comp) <= 1e-9 or time.process_time() - t0 > args.time_limit:
                break
            factors = engine.factorise(z)
            dv, ds, dw, dy = engine.direction(z, factors, r_b, r_h, r_c, -z.s * z.y)
            a = min(engine.max_step(z.s, ds), engine.max_step(z.y, dy))
            mu_aff = float((z.s + a * ds) @ (z.y + a * dy)) / p
            sigma = min(1.0, max((max(mu_aff, 0.0) / mu) ** 3, args.sigma_min))
            r_mu = sigma * mu - z.s * z.y - ds * dy
            dv, ds, dw, dy = engine.refined_direction(z, factors, r_b, r_h, r_c, r_mu)
            alpha = 0.9995 * min(engine.max_step(z.s, ds), engine.max_step(z.y, dy))
            while alpha > 1e-10:
                s, y = z.s + alpha * ds, z.y + alpha * dy
                if (s * y).min() >= args.gamma * float(s @ y) / p:
                    break
                alpha *= 0.7
            z = IPMIterate(z.v + alpha * dv, z.s + alpha * ds, z.w + alpha * dw, z.y + alpha * dy)
            if k % 10 == 0:
                print(f"  {k}: mu {mu:.2e} sigma {sigma:.2f} step {alpha:.3f} complementarity {comp:.1e}", flush=True)
    out = engine.outcome_at(z)
    sol = static_lp_solution(lp, out)
    return [result_row("path", f"gamma {args.gamma:g}, sigma_min {args.sigma_min:g}", ops, sol, k,
                       time.process_time() - t0, out.status.value)]


def route_gap(ops, args) -> list[dict]:
    from blockmpec.solvers.engines.highs import static_lp_solution

    lp = step_lp(ops)
    rows = []
    t0 = time.process_time()
    engine = interior(ops, tol=1e-9, max_iterations=200, time_limit=args.time_limit)
    z, total = None, 0
    for fraction in (float(f) for f in args.fractions.split(",")):
        if args.mode == "sweep":
            t0 = time.process_time()
            engine = interior(ops, tol=1e-9, max_iterations=200, time_limit=args.time_limit)
            z, total = None, 0
        set_dual_slope(engine, ops.dilatancy + fraction * (ops.friction - ops.dilatancy), ops.dilatancy)
        engine.start_iterate = None
        if z is not None:
            z = z.copy()
            floor = np.sqrt(args.mu_target)
            z.s, z.y = np.maximum(z.s, floor), np.maximum(z.y, floor)
            engine.start_iterate = z
        engine.best_error, engine.best_iterate = np.inf, None
        out = engine.solve()
        total += out.iterations
        z = engine.best_iterate
        sol = static_lp_solution(lp, out)
        tan_psi = float(np.mean(ops.dilatancy + fraction * (ops.friction - ops.dilatancy)))
        print(f"  gap fraction {fraction:g} (tan psi {tan_psi:.3g}): {out.status.value} {out.iterations} it, "
              f"best residual {engine.best_error:.1e}", flush=True)
        rows.append({"route": f"gap {args.mode}", "setting": f"tan psi {tan_psi:.3g}", "blocks": ops.n_free_blocks,
                     "iterations": out.iterations, "total_iterations": total, "cpu_s": time.process_time() - t0,
                     "status": out.status.value, "multiplier": sol.multiplier if out.status.is_success else None,
                     "best_residual": engine.best_error})
    if args.mode == "homotopy" and float(args.fractions.split(",")[-1]) == 0.0:
        rows.append(result_row("gap homotopy", "end", ops, sol, total, time.process_time() - t0, out.status.value))
    return rows


def route_trust(ops, args) -> list[dict]:
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.engines.interior_fixed_point import InteriorFixedPoint

    class MovingCohesion(InteriorFixedPoint):
        """The LP (5) whose ``n*`` moves at well-centred iterates by a bounded step."""

        change = 1.0

        def before_iteration(self, it):
            mu = float(it.s @ it.y) / it.s.size
            n = np.minimum(self.normal_forces(it), 0.0)
            step = n - self.n_star
            size = float(np.linalg.norm(step)) / max(float(np.linalg.norm(n)), 1e-300)
            if float(np.min(it.s * it.y)) >= args.centrality * mu:
                self.set_n_star(self.n_star + min(1.0, args.radius / max(size, 1e-300)) * step)
            self.change = float(np.linalg.norm(n - self.n_star)) / max(float(np.linalg.norm(n)), 1e-300)

        def gap(self, it):
            return max(super().gap(it), self.change)

    lp = step_lp(ops)
    t0 = time.process_time()
    engine = interior(ops, MovingCohesion, coupling="fixed", tol=1e-9, max_iterations=args.iterations, time_limit=300)
    out = engine.solve()
    sol = static_lp_solution(lp, out)
    return [result_row("trust", f"radius {args.radius:g}, centrality {args.centrality:g}", ops, sol, out.iterations,
                       time.process_time() - t0, out.status.value)]


def route_active_set(ops, args) -> list[dict]:
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.linalg.block_ipm import IPMIterate, single_blas_thread

    lp = step_lp(ops)
    t0 = time.process_time()
    engine = interior(ops, tol=1e-9)
    engine.solve()
    z = engine.best_iterate
    active = z.s < z.y
    v, w, k = z.v.copy(), z.w.copy(), 0
    with single_blas_thread():
        for k in range(1, args.iterations + 1):
            S, Y = np.where(active, args.delta, 1.0), np.where(active, 1.0, args.delta)
            it = IPMIterate(v, S, w, Y)
            r_b, r_h, r_c = engine.residuals(it)
            dv, ds, dw, dy = engine.refined_direction(it, engine.factorise(it), r_b, r_h, r_c, -S * Y)
            v, w, s, y = v + dv, w + dw, S + ds, Y + dy
            switched = (y > s) != active
            z = IPMIterate(v.copy(), np.maximum(s, 0.0), w.copy(), np.maximum(y, 0.0))
            print(f"  {k}: {int(switched.sum())} of {active.size} rows switch, residuals {engine.measures(z)}",
                  flush=True)
            if max(engine.measures(z)) <= 1e-9 or not switched.any():
                break
            active = y > s
    out = engine.outcome_at(z)
    sol = static_lp_solution(lp, out)
    return [result_row("active-set", f"delta {args.delta:g}", ops, sol, k, time.process_time() - t0,
                       out.status.value)]


def route_mixed(ops, args) -> list[dict]:
    """Newton on a fraction ``theta`` of the gap, the rest lagged: primal friction rows
    ``+-t + (tan(psi) + theta g) n <= -(1 - theta) g n*`` with ``n* := n`` before every iteration (at
    ``n = n*`` the MCP (3)); ``theta = 1`` is the interior engine, ``theta = 0`` its lagged coupling."""
    import scipy.sparse as sp

    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.engines.interior_fixed_point import InteriorFixedPoint

    theta = args.theta

    class Mixed(InteriorFixedPoint):
        change = 1.0

        def before_iteration(self, it):
            n = np.minimum(self.normal_forces(it), 0.0)
            self.change = float(np.linalg.norm(n - self.n_star)) / max(float(np.linalg.norm(n)), 1e-300)
            self.set_n_star(n)
            super().before_iteration(it)

        def gap(self, it):
            return max(super().gap(it), (1 - theta) * self.change)

    lp = step_lp(ops)
    t0 = time.process_time()
    engine = interior(ops, Mixed, coupling="fixed", tol=1e-9, max_iterations=args.iterations,
                      time_limit=args.time_limit)
    factor = engine.cohesion_factor.copy()
    rows, cols = engine.friction_position, np.repeat(engine.normal_columns, 2)
    extra = sp.csr_array((engine.in_scale[rows] * np.repeat(theta * factor, 2) * engine.column_scale[cols],
                          (rows, cols)), shape=engine.G.shape)
    engine.G = (engine.G + extra).tocsr()
    engine.g_blocks = engine.dense_blocks(engine.G)
    engine.symmetric = theta == 0
    engine.cohesion_factor = (1 - theta) * factor
    out = engine.solve()
    sol = static_lp_solution(lp, out)
    return [result_row("mixed", f"theta {theta:g}", ops, sol, out.iterations, time.process_time() - t0,
                       out.status.value)]


def route_pieces(ops, args) -> list[dict]:
    """From the interior engine's best iterate (its stalled point, aim ``--fold``, no continuation) straight to
    ``nlp``'s split piece LPs (:func:`~blockmpec.solvers.engines.piece_lp.piece_descent`): a mechanism on the
    pairs whose slack is (relatively) the smaller side, then the static LP with ``G_i x = 0`` on its support.
    ``--static-engine``: the static halves' engine (``auto``: the block IPM from 4,000 pairs)."""
    from blockmpec.deadline import Deadline
    from blockmpec.formulations import compile_mcp
    from blockmpec.solvers.engines.piece_lp import piece_descent
    from blockmpec.solvers.engines.scaling import LoadUnits

    lp = step_lp(ops)
    t0 = time.process_time()
    out, start = stalled_point(lp, ops, args.fold, args)
    rows = [result_row("pieces", f"interior start, aim {args.fold:g}", ops, start, out.iterations,
                       time.process_time() - t0, out.status.value)]
    form = compile_mcp(ops)
    t1 = time.process_time()
    descent = piece_descent(form, LoadUnits.of(ops).mcp(form), form.pack(start),
                            deadline=Deadline(args.time_limit), static_engine=args.static_engine)
    first = "; ".join(f"{r['lp']} {r['status']} (support {r.get('support', '-')})" for r in descent.trace[:3])
    sol = form.unpack(descent.w) if descent.w is not None else bm.Solution()
    rows.append(result_row("pieces", f"piece LPs, static {args.static_engine}", ops, sol, descent.lp_solves,
                           time.process_time() - t1, descent.status.value, first_lps=first))
    return rows


def route_ties(ops, args) -> list[dict]:
    """The interior engine (aim ``--fold``, or each of ``--aims``; no continuation) on the wall with every interface's friction
    coefficient lowered at random (seed 1) by up to the fraction ``eps`` of ``--eps`` (0: the wall itself), to
    break the running bond's ties.  Lowered friction keeps a solution of the perturbed (3) statically
    admissible for the wall itself, so the worst residual of (3) is measured on the wall itself (about ``eps``
    where a perturbed friction row is active)."""
    wall = named_wall(args.wall)
    aims = [float(v) for v in args.aims.split(",")] if args.aims else [args.fold]
    rows = []
    for eps in (float(v) for v in args.eps.split(",")):
        perturbed_ops = bm.assemble(lowered_friction(wall, eps))
        lp = step_lp(perturbed_ops)
        for aim in aims:
            t0 = time.process_time()
            out, sol = stalled_point(lp, perturbed_ops, aim, args)
            rows.append(result_row("ties", f"friction lowered by up to {eps:g}, aim {aim:g}", ops, sol,
                                   out.iterations, time.process_time() - t0, out.status.value))
    return rows


def hybrid_ops(ops, coupled: np.ndarray):
    """The wall with the dilatancy gap kept only on the ``coupled`` interfaces: ``tan(psi) = tan(phi)`` (associative
    flow, monotone) on the others."""
    import dataclasses

    dilatancy = np.where(coupled, ops.dilatancy, ops.friction)
    return dataclasses.replace(ops, dilatancy=dilatancy, V_f=ops.friction_operator(dilatancy))


def route_hybrid(ops, args) -> list[dict]:
    """Newton on (3) with the non-associative coupling only where the mechanism slides.  On an interface that does
    not slide (friction multipliers 0) the dual rows' slope does not enter (3), so a solution of the *hybrid*
    problem (gap kept on a set ``S``, associative elsewhere) whose friction multipliers vanish outside ``S`` solves
    (3) itself.  ``S`` starts as the interfaces whose friction multiplier in the associative LP's solution is at
    least ``--share`` of the largest; each round runs the interior engine (no aim, no continuation) on the hybrid
    problem, cold or, with ``--continued``, by :func:`continue_central_path` from the previous round's answer
    (``s, y`` raised by ``sqrt(mu_target)``), then adds to ``S`` every interface outside it whose friction
    multiplier exceeds ``--outside`` of the largest; it stops when none does (at most ``--steps`` rounds).  The
    worst residual of (3) is measured on the wall itself."""
    from blockmpec.deadline import Deadline
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.engines.interior_fixed_point import continue_central_path

    t0 = time.process_time()
    lp_result = bm.solve(ops, "static-lp")
    rows = [result_row("hybrid", "associative LP", ops, lp_result.solution, lp_result.iterations,
                       time.process_time() - t0, lp_result.status.value)]
    flow = lp_result.solution.z_f.reshape(-1, 2).sum(axis=1)
    coupled = flow >= args.share * flow.max()
    previous = None
    for round_ in range(args.steps):
        hybrid = hybrid_ops(ops, coupled)
        lp = step_lp(hybrid)
        engine = interior(hybrid, tol=args.tol, max_iterations=args.iterations, time_limit=args.time_limit)
        t0 = time.process_time()
        if previous is None or not args.continued:
            out = engine.solve()
            end, how, iterations, failure = engine.best_iterate, "cold", out.iterations, out.status.value
        else:
            start = previous.copy()
            floor = np.sqrt(args.mu_target)
            start.s = np.maximum(engine.h - engine.G @ start.v, 0.0) + floor
            start.y = start.y + floor
            end, info = continue_central_path(engine, start, tol=args.tol, deadline=Deadline(args.time_limit))
            how, iterations = f"continued ({info['steps']} steps)", info["factorisations"]
            failure = f"numerical (continuation ended at mu {info['mu']:.1e})"
        cpu = time.process_time() - t0
        outcome = engine.outcome_at(end) if end is not None else None
        sol = static_lp_solution(lp, outcome) if outcome is not None and outcome.status.is_success else bm.Solution()
        setting = f"round {round_}, |S| = {int(coupled.sum())}, {how}"
        if sol.multiplier is None:
            rows.append(result_row("hybrid", setting, ops, sol, iterations, cpu, failure))
            break
        flow = sol.z_f.reshape(-1, 2).sum(axis=1)
        outside = (flow > args.outside * flow.max()) & ~coupled
        rows.append(result_row("hybrid", setting, ops, sol, iterations, cpu, outcome.status.value,
                               sliding_outside=int(outside.sum())))
        if not outside.any():
            break
        coupled |= outside
        previous = end
    return rows


def route_smoke(ops, args) -> list[dict]:
    """The smallest runs of two routes, checked (CI; ``--wall 10x10``).

    ``ties`` (aim 0.1; friction lowered by 0, 1e-6, 1e-3): the wall itself is solved and verified at 1e-8; a solution
    of the perturbed (3) is within about the perturbation of the wall's own (3).  ``hybrid`` (``--share 0.1``): ``S``
    too small at first (associative sliding outside it, not a solution of (3)); the last round has nothing sliding
    outside ``S``, solves the wall's (3) at 1e-8 and (Radenkovic) lies at or below the associative multiplier."""
    failures = []
    args.fold, args.eps, args.aims = 0.1, "0,1e-6,1e-3", ""
    plain, small, large = rows = route_ties(ops, args)
    if not (plain["status"] == "optimal" and plain["verified"]):
        failures.append(f"ties: the wall itself ended {plain['status']}, worst residual {plain['worst_value']:.1e}")
    if not (small["status"] == "optimal" and small["worst_value"] <= 1e-6):
        failures.append(f"ties: friction lowered by 1e-6 ended {small['status']}, worst {small['worst_value']:.1e}")
    if not large["worst_value"] > small["worst_value"]:
        failures.append("ties: a larger perturbation did not leave a larger residual on the wall")
    args.share = 0.1
    associative, *rounds = hybrid = route_hybrid(ops, args)
    first, last = rounds[0], rounds[-1]
    if not (first.get("sliding_outside", 0) > 0 and not first["verified"]):
        failures.append("hybrid: the first S is not too small (nothing slides outside it, or it solves (3))")
    if not (last.get("sliding_outside") == 0 and last["status"] == "optimal" and last["verified"]):
        failures.append(f"hybrid: the last round ended {last['status']}, {last.get('sliding_outside')} sliding outside S")
    if not last["multiplier"] <= associative["multiplier"] + 1e-9:
        failures.append("hybrid: the answer lies above the associative multiplier")
    for line in failures:
        print(f"smoke check failed: {line}")
    if failures:
        raise SystemExit(1)
    print("smoke: the ties and hybrid routes behave as recorded")
    return rows + hybrid


ROUTES = {"steps": route_steps, "mixed": route_mixed, "path": route_path, "gap": route_gap, "trust": route_trust,
          "active-set": route_active_set, "pieces": route_pieces, "ties": route_ties,
          "hybrid": route_hybrid, "smoke": route_smoke}


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("route", choices=sorted(ROUTES))
    parser.add_argument("--wall", default="20x50", help="CxB: courses x blocks per course")
    parser.add_argument("--cold", action="store_true", help="first time one cold static-lp")
    parser.add_argument("--time-limit", type=float, default=300.0)
    parser.add_argument("--iterations", type=int, default=150,
                        help="path, trust, active-set, pieces, hybrid: most iterations")
    # steps
    parser.add_argument("--fold", type=float, default=0.0)
    parser.add_argument("--mu-target", type=float, default=1e-7)
    parser.add_argument("--relax", type=float, default=1.0)
    parser.add_argument("--accel", choices=("none", "anderson"), default="none")
    parser.add_argument("--memory", type=int, default=5)
    parser.add_argument("--steps", type=int, default=25)
    parser.add_argument("--tol", type=float, default=1e-9)
    # path
    parser.add_argument("--gamma", type=float, default=1e-3)
    parser.add_argument("--sigma-min", type=float, default=0.1)
    # gap
    parser.add_argument("--fractions", default="0.77,0.46,0", help="fractions of the dilatancy gap (1: associative)")
    parser.add_argument("--mode", choices=("sweep", "homotopy"), default="homotopy")
    # trust
    parser.add_argument("--radius", type=float, default=0.1)
    parser.add_argument("--centrality", type=float, default=1e-3)
    # mixed
    parser.add_argument("--theta", type=float, default=0.7)
    # active set
    parser.add_argument("--delta", type=float, default=1e-12)
    # pieces
    parser.add_argument("--static-engine", choices=STATIC_ENGINES, default="auto",
                        help="pieces: the static halves' engine (auto: the block IPM from 4,000 pairs)")
    # ties
    parser.add_argument("--eps", default="0,1e-6,1e-4,1e-2",
                        help="ties: fractions by which each interface's friction is lowered at most (0: none)")
    parser.add_argument("--aims", default="", help="ties: comma-separated aim weights (default: --fold)")
    # hybrid
    parser.add_argument("--share", type=float, default=1e-6,
                        help="hybrid: S starts as the interfaces with at least this share of the associative LP's "
                             "largest friction multiplier")
    parser.add_argument("--outside", type=float, default=1e-6,
                        help="hybrid: an interface outside S slides when its friction multiplier exceeds this share "
                             "of the largest")
    parser.add_argument("--continued", action="store_true",
                        help="hybrid: later rounds continue the previous round's central path instead of a cold run")
    args = parser.parse_args(argv)
    if args.route == "smoke":
        args.wall = "10x10"
    ops = bm.assemble(named_wall(args.wall))
    rows = []
    if args.cold:
        from fixed_point_ratio import timed_solve

        res, cpu = timed_solve(ops, "static-lp", algorithm="auto", time_limit=args.time_limit)
        rows.append({"route": "cold static-lp", "setting": "block IPM", "blocks": ops.n_free_blocks,
                     "iterations": res.iterations, "cpu_s": cpu, "status": res.status.value,
                     "multiplier": res.multiplier, "verified": bool(res.success)})
        print(rows[-1], flush=True)
    rows += ROUTES[args.route](ops, args)
    columns = [("route", "route", "{}"), ("setting", "setting", "{}"), ("blocks", "blocks", "{}"),
               ("iterations", "iterations", "{}"), ("cpu_s", "CPU s", "{:.3g}"), ("status", "status", "{}"),
               ("multiplier", "lam", "{:.6g}"), ("worst_value", "worst residual of (3)", "{:.1e}"),
               ("verified", "verified 1e-8", "{}")]
    print(markdown(rows, columns))
    print(f"wrote {write_csv(OUT / f'{args.route}_{args.wall}.csv', rows)}")
    return rows


if __name__ == "__main__":
    main()

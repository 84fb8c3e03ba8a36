r"""Issue 12, a measured negative result: lower bounds on (4) from the normal forces alone.

Every solution ``(lam, x, u, z)`` of (3) is an optimal point of the fixed point's LP (5)
at its own normal forces, ``n* = n``, so ``lam = L(n)`` with::

    L(n*) = max lam  s.t.  E x + f_d + lam f_l = 0,  N_u^T x <= 0,
                           |t_k| <= -n_k tan(psi_k) - n*_k (tan(phi_k) - tan(psi_k)).

``L`` is nonincreasing in each ``n*_k <= 0`` (less compression, less cohesion, a smaller
feasible set) and concave (the optimal value of a max-LP in its right-hand side).  Hence,
for a box ``l <= n <= u`` that holds the normal forces of every solution of (3) with
``lam`` in ``[a, b]`` (found by optimisation-based bound tightening over the statically
admissible set ``S = {equilibrium, N_u^T x <= 0, N_f^T x <= 0, a <= lam <= b}``)::

    lam >= max(a, L(u))      for every solution of (3) in the box,

and the box is empty of solutions when ``L(u) > b``.  This script measures how far that
bound goes, two ways:

``vertices``  ``min L(n)`` over sampled vertices of ``S`` (random objectives): an *upper*
              estimate of ``min_{n in S} L(n)``, the best any relaxation that keeps the
              statics and the mechanism feasible but drops their complementarity can do;
``bnb``       a best-first branch and bound on (``lam`` interval, ``n`` box) with the bound
              above, OBBT at every node, bisection of ``lam`` while its interval is wide and
              of the ``n_k`` with the largest friction sensitivity after that; its bound after
              ``--time-limit`` CPU seconds.

Usage::

    python studies/lab/normal_force_bound.py vertices --walls 2x2,3x2 --lam-floors none,0.5,0.6
    python studies/lab/normal_force_bound.py bnb --walls 2x2,3x2 --time-limit 60
"""

from __future__ import annotations

import argparse
import heapq
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm
from blockmpec.formulations import compile_linear, static_lp
from blockmpec.formulations.static_lp import modified_lp
from blockmpec.solvers.engines.highs import HighsLP

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _walls import named_wall  # noqa: E402

TOL = 1e-9


def _cold_highs(lp) -> HighsLP:
    """The project's HiGHS wrapper on ``lp`` at feasibility tolerances 1e-9; :func:`_solve_cold` runs it
    cold (warm re-solves after cost and bound changes were seen to report a feasible LP infeasible)."""
    engine = HighsLP(lp, "dual-simplex")
    engine.highs.setOptionValue("primal_feasibility_tolerance", TOL)
    engine.highs.setOptionValue("dual_feasibility_tolerance", TOL)
    return engine


def _solve_cold(engine: HighsLP):
    """``(column values, row duals)``, or None unless optimal."""
    engine.highs.clearSolver()
    out = engine.solve()
    return (out.v, out.row_dual) if out.status is bm.Status.OPTIMAL else None


class NormalForceBound:
    """``L(n*)`` and OBBT of the normal forces over ``S`` for one structure (see the module docstring)."""

    def __init__(self, structure: bm.Structure) -> None:
        ops = bm.assemble(structure)
        self.c = ops.n_interfaces
        self.tan_phi, self.cohesion_slope = ops.friction, ops.friction - ops.dilatancy
        self.static = _cold_highs(compile_linear(static_lp(ops)))
        self.all_static = np.arange(self.static.lp.c.size, dtype=np.int32)
        lp = self.static.lp
        self.n_col = lp.columns["x"][3 * np.arange(self.c) + 1]
        self.lam_col = int(lp.columns["lam"][0])
        self.step = _cold_highs(compile_linear(modified_lp(ops, np.zeros(self.c))))
        self.friction_rows = self.step.lp.rows["friction"].astype(np.int32)
        self.lp_solves = 0

    def L(self, n_star: np.ndarray):
        """``(L(n*), n, |t| + n tan(phi), friction multipliers per interface)`` of the step LP at ``n*``."""
        step, rows = self.step, self.friction_rows
        step.set_row_upper(rows, np.repeat(-n_star * self.cohesion_slope, 2))
        self.lp_solves += 1
        v, y = _solve_cold(step)
        x = step.lp.values("x", v)
        n, t = x[1::3], x[0::3]
        return float(step.lp.values("lam", v)[0]), n, np.abs(t) + n * self.tan_phi, -y[rows].reshape(-1, 2).sum(1)

    def _static_optimum(self, cost: np.ndarray, lo, up, lam_lo: float, lam_hi: float):
        lp, h = self.static.lp, self.static.highs
        lower, upper = lp.col_lower.copy(), lp.col_upper.copy()
        lower[self.n_col], upper[self.n_col] = lo, up
        lower[self.lam_col], upper[self.lam_col] = lam_lo, lam_hi
        h.changeColsBounds(self.all_static.size, self.all_static, lower, upper)
        h.changeColsCost(self.all_static.size, self.all_static, cost)
        self.lp_solves += 1
        return _solve_cold(self.static)

    def tighten(self, lo, up, lam_lo: float, lam_hi: float):
        """OBBT of every ``n_k`` over ``S`` with ``lam`` in ``[lam_lo, lam_hi]``; None if empty."""
        lo, up = lo.copy(), up.copy()
        for k in range(self.c):
            for sense in (-1.0, 1.0):  # max n_k, then min n_k
                cost = np.zeros(self.all_static.size)
                cost[self.n_col[k]] = sense
                out = self._static_optimum(cost, lo, up, lam_lo, lam_hi)
                if out is None:
                    return None
                value = out[0][self.n_col[k]]
                margin = 1e-7 * max(1.0, abs(value))
                if sense < 0:
                    up[k] = min(up[k], value + margin)
                else:
                    lo[k] = max(lo[k], value - margin)
        return lo, up

    def sampled_vertices(self, lam_lo: float, lam_hi: float, samples: int, seed: int = 0) -> float:
        """``min L(n)`` over vertices of ``S`` (``lam`` in ``[lam_lo, lam_hi]``) hit by random objectives."""
        rng = np.random.default_rng(seed)
        best = np.inf
        free = np.full(self.c, -np.inf), np.zeros(self.c)
        for _ in range(samples):
            cost = np.zeros(self.all_static.size)
            cost[self.n_col] = rng.standard_normal(self.c) * (rng.random(self.c) < 0.5)
            cost[self.lam_col] = rng.standard_normal()
            out = self._static_optimum(cost, *free, lam_lo, lam_hi)
            if out is not None:
                best = min(best, self.L(np.minimum(out[0][self.n_col], 0.0))[0])
        return best


def branch_and_bound(structure: bm.Structure, time_limit: float) -> dict:
    """The ``bnb`` part: best-first search on (``lam`` interval, ``n`` box); incumbent from ``fixed-point``."""
    t0 = time.process_time()
    incumbent = bm.solve(structure, "fixed-point")
    inc = incumbent.multiplier if incumbent.success else np.inf
    nb = NormalForceBound(structure)
    c = nb.c
    floor = nb.L(np.zeros(c))[0]  # L(0) bounds every solution: n <= 0

    def node(a, b, lo, up):
        box = nb.tighten(lo, up, a, b)
        if box is None:
            return None
        lam, n, violation, zf = nb.L(box[1])
        if lam > b + TOL * max(1.0, abs(b)):
            return None
        return (max(a, lam), *box, (lam, n, violation, zf))

    heap, count, nodes = [], 0, 0
    root = node(floor, inc, np.full(c, -1e6), np.zeros(c))
    if root is not None:
        heap.append((root[0], 0, floor, inc, *root[1:]))
    while heap and time.process_time() - t0 < time_limit:
        bound, _, a, b, lo, up, (lam, n, violation, zf) = heapq.heappop(heap)
        if bound >= inc - 1e-6 * max(1.0, abs(inc)):
            heap = []
            break
        nodes += 1
        slide = zf > TOL
        if np.all(violation <= TOL) and np.all(np.abs(up - n)[slide] <= TOL) and lam >= a - TOL:
            inc = min(inc, lam)  # the step LP's point solves (3)
            continue
        if b - max(a, lam) > 0.02 * max(1.0, abs(b)) or not slide.any():
            m = 0.5 * (max(a, lam) + b)
            children = [(a, m, lo, up), (m, b, lo, up)]
        else:
            k = int(np.argmax(np.where(slide, zf * nb.cohesion_slope * np.maximum(up - n, 0.0), 0.0)))
            w, m = up[k] - lo[k], n[k]
            if not lo[k] + 0.05 * w <= m <= up[k] - 0.05 * w:
                m = 0.5 * (lo[k] + up[k])
            children = []
            for x0, x1 in ((lo[k], m), (m, up[k])):
                clo, cup = lo.copy(), up.copy()
                clo[k], cup[k] = x0, x1
                children.append((a, b, clo, cup))
        for ca, cb, clo, cup in children:
            child = node(ca, min(cb, inc), clo, cup)
            if child is not None and child[0] < inc - 1e-6 * max(1.0, abs(inc)):
                count += 1
                heapq.heappush(heap, (child[0], count, ca, cb, *child[1:]))
    return {"blocks": structure.n_free, "incumbent": inc, "bound": heap[0][0] if heap else inc,
            "closed": not heap, "nodes": nodes, "lp_solves": nb.lp_solves, "cpu_s": time.process_time() - t0}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("part", choices=["vertices", "bnb"])
    ap.add_argument("--walls", default="2x2,3x2", help="running-bond walls CxB")
    ap.add_argument("--lam-floors", default="none,0.5,0.6", help="vertices: lower limits a of lam on S")
    ap.add_argument("--samples", type=int, default=400)
    ap.add_argument("--time-limit", type=float, default=60.0)
    args = ap.parse_args(argv)
    if args.part == "vertices":
        print("| wall | lam on S | min L(n) over sampled vertices of S |\n| --- | --- | ---: |")
        for spec in args.walls.split(","):
            s = named_wall(spec)
            nb = NormalForceBound(s)
            top = bm.solve(s, "fixed-point").multiplier
            for floor in args.lam_floors.split(","):
                a = -np.inf if floor == "none" else float(floor)
                v = nb.sampled_vertices(a, top, args.samples)
                print(f"| {spec} ({s.n_free} blocks) | [{floor}, {top:.4g}] | {v:.4f} |", flush=True)
    else:
        print("| wall | blocks | incumbent (fixed-point) | bound | closed | nodes | LP solves | CPU |\n"
              "| --- | ---: | ---: | ---: | --- | ---: | ---: | ---: |")
        for spec in args.walls.split(","):
            r = branch_and_bound(named_wall(spec), args.time_limit)
            print(f"| {spec} | {r['blocks']} | {r['incumbent']:.4f} | {r['bound']:.4f} | {r['closed']} | "
                  f"{r['nodes']:,} | {r['lp_solves']:,} | {r['cpu_s']:.0f} s |", flush=True)


if __name__ == "__main__":
    main()

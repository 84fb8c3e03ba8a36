"""Timing of the associative pipeline on running-bond walls of growing size.

For each wall and LP algorithm: structure generation (with interface detection),
operator assembly, Pyomo model build, compilation to matrices, engine load, cold
solve, lam, the ratio of model construction (build + compile) to the solve, the
largest residual of the shared verifier (``blockmpec.verify.residuals``, associative)
and the peak resident memory.  Each case runs in a fresh process, so its peak memory
is its own.  Times are wall-clock (``*_s``) and CPU time of the process (``*_cpu_s``):
on a shared, loaded machine the CPU times are the ones to compare (the solve is
single-threaded apart from small BLAS calls).  With two processes for ``K`` (``factor_processes``, the block IPM's
default from 30,000 rows of ``K`` when two CPUs are usable) the worker process's CPU is reported apart
(``worker_cpu_s``) and not in the peak memory; compare the wall-clock of such runs.  For the block IPM also the fill-reducing ordering of ``K``, its
factorisation (``--factorisations``: ``auto``, ``supernodal``, ``superlu``), its per-interface kernels
(``--kernels``: ``auto``, ``numpy``, ``compiled``, the last needing numba), the number of factorisations and
solves with ``K`` and their CPU time.
Algorithms are those of ``static-lp`` (``blockmpec.solvers.plan.LP_ALGORITHMS``):
HiGHS's ``dual-simplex``, ``primal-simplex``, ``ipm`` (with crossover), the
``block-ipm``, or ``auto``; and, for a side-by-side measurement of a library
alternative, Clarabel (pip ``clarabel``,
Apache-2.0, not a dependency of blockmpec: ``clarabel`` with its default tolerances 1e-8, ``clarabel-1e-10``
with gap and feasibility tolerances 1e-10; :class:`ClarabelLP`).  Usage::

    python studies/lab/lp_timing.py [--sizes 100,1000,10000] [--algorithms auto] [--time-limit 600]
                                [--walls 100x100,316x316] [--orderings auto,mmd] [--ipm-settings previous,default]
                                [--factorisations superlu,supernodal] [--kernels numpy,compiled]
                                [--algorithms block-ipm,clarabel,clarabel-1e-10]

``--walls CxB`` gives walls of ``courses=C, blocks_per_course=B`` instead of sizes; options of
:func:`blockmpec.cases.wall` may follow after colons, ``--walls 100x100:mu=0.3,100x100:bond=stack``.

Writes ``studies/output/lp_timing/lp_timing.csv`` and, per block IPM run, its iteration trace
``trace_<wall>_<settings>.csv``.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm
from blockmpec.errors import OptionError
from blockmpec.formulations import compile_linear, pause_gc, static_lp
from blockmpec.result import Status
from blockmpec.solvers.engines.highs import LPOutcome
from blockmpec.solvers.engines.lp_engine import cold_lp_engine

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
import _walls as walls  # noqa: E402
from _clarabel import ClarabelProblem  # noqa: E402
from _ipm_settings import named_settings  # noqa: E402
from _tables import peak_memory_mb, write_csv  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "lp_timing"


def wall_or_size(wall: str) -> bm.Structure:
    """:func:`_walls.wall_or_size`, a malformed name the script's one-line exit."""
    try:
        return walls.wall_or_size(wall)
    except (OptionError, ValueError) as error:
        raise SystemExit(f"lp_timing: {error}") from None


#: Clarabel's outcome -> :class:`Status` (any other: numerical)
CLARABEL_STATUS = {"Solved": Status.OPTIMAL, "AlmostSolved": Status.ACCEPTABLE, "MaxTime": Status.TIME_LIMIT,
                   "MaxIterations": Status.ITERATION_LIMIT, "PrimalInfeasible": Status.INFEASIBLE,
                   "DualInfeasible": Status.UNBOUNDED}


class ClarabelLP:
    """Clarabel (:class:`_clarabel.ClarabelProblem`) on the static LP in the same load units as the other engines
    (``R A C``, ``R b``, ``C c``; its columns are free); the answer in the compiled LP's units with HiGHS's row-dual
    signs, which :func:`static_lp_solution` reads.  ``tolerance``: Clarabel's gap and feasibility tolerances (None:
    its defaults)."""

    def __init__(self, lp, ops, time_limit: float, tolerance: float | None) -> None:
        from blockmpec.solvers.engines.scaling import LoadUnits

        if np.any(np.isfinite(lp.col_lower)) or np.any(np.isfinite(lp.col_upper)):
            raise ValueError("ClarabelLP: the static LP's columns are free")
        self.lp = lp
        self.scaling = LoadUnits.of(ops).static(lp)
        scaled = self.scaling.apply(lp)
        self.problem = ClarabelProblem(scaled.A, scaled.c, scaled.row_lower, scaled.row_upper, lp.col_lower,
                                       lp.col_upper)
        self.settings = {"time_limit": time_limit if np.isfinite(time_limit) else 1e9}
        if tolerance is not None:
            self.settings.update(tol_gap_abs=tolerance, tol_gap_rel=tolerance, tol_feas=tolerance)

    def solve(self, deadline=None) -> LPOutcome:
        """Solve within the ``time_limit`` given (``deadline`` is the other engines' and not read)."""
        x, row_dual, raw, iterations = self.problem.solve(**self.settings)
        v = self.scaling.primal(x)
        return LPOutcome(CLARABEL_STATUS.get(raw, Status.NUMERICAL), f"clarabel: {raw}", float(self.lp.c @ v), v,
                         self.scaling.dual(row_dual), iterations, raw)


def time_one(wall: str, algorithm: str, time_limit: float = float("inf"), ordering: str = "auto",
             max_iterations: int | None = None, ipm_settings: str = "default", factorisation: str = "auto",
             kernels: str = "auto", factor_processes: str | int | None = None,
             compiled_solves: str | bool | None = None, compiled_factorisation: str | bool | None = None) -> dict:
    """One cold solve of the static LP of ``wall`` (a size ``"1000"`` or ``"CxB"`` courses x blocks per course);
    ``factor_processes``, ``compiled_solves`` and ``compiled_factorisation`` (block IPM), when given, override those
    of ``ipm_settings``."""
    from blockmpec.deadline import Deadline
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.engines.scaling import LoadUnits
    from blockmpec.solvers.linalg.block_ipm import BlockIPM

    t0 = time.perf_counter()
    s = wall_or_size(wall)
    t1 = time.perf_counter()
    ops = bm.assemble(s)
    t2, c2 = time.perf_counter(), time.process_time()
    problem = pause_gc(static_lp)(ops)  # as compiled_linear builds it
    t3, c3 = time.perf_counter(), time.process_time()
    lp = compile_linear(problem)
    t4, c4 = time.perf_counter(), time.process_time()
    if algorithm.startswith("clarabel"):
        engine = ClarabelLP(lp, ops, time_limit, tolerance=1e-10 if algorithm == "clarabel-1e-10" else None)
    else:
        engine = cold_lp_engine(lp, algorithm, LoadUnits.of(ops))  # as static-lp runs it: in load units
    if isinstance(engine, BlockIPM):
        engine.ordering = ordering
        engine.factorisation = factorisation
        engine.settings(**{**named_settings(ipm_settings), "kernels": kernels})
        if factor_processes is not None:
            engine.settings(factor_processes=factor_processes)
        if compiled_solves is not None:
            engine.settings(compiled_solves=compiled_solves)
        if compiled_factorisation is not None:
            engine.settings(compiled_factorisation=compiled_factorisation)
        if max_iterations is not None:  # a per-iteration cost measurement (status: iteration limit)
            engine.max_iterations = max_iterations
    t5, c5 = time.perf_counter(), time.process_time()
    out = engine.solve(deadline=Deadline(time_limit))
    t6, c6 = time.perf_counter(), time.process_time()
    # a point is verified even when its engine did not claim success (Clarabel "AlmostSolved"), to say how far off it is
    has_point = bool(np.all(np.isfinite(out.v)))
    lam = float(lp.values("lam", out.v)[0]) if has_point else math.nan
    residual = (max(bm.verify.residuals(ops, static_lp_solution(lp, out), associative=True).values())
                if has_point else math.nan)
    factoriser = engine.factoriser if isinstance(engine, BlockIPM) else None
    if isinstance(engine, BlockIPM) and engine.trace:  # mu, steps, centrality, solves per iteration
        write_csv(OUT / f"trace_{wall.replace(':', '_')}_{ipm_settings}_{factorisation}_{kernels}.csv", engine.trace)
    return {
        "wall": wall, "blocks": s.n_free, "interfaces": len(s.interfaces), "rows": lp.A.shape[0], "columns": lp.A.shape[1],
        "generate_s": t1 - t0, "assemble_s": t2 - t1, "pyomo_build_s": t3 - t2, "compile_s": t4 - t3,
        "load_s": t5 - t4, "solve_s": t6 - t5, "build_over_solve": (t4 - t2) / (t6 - t5),
        "pyomo_build_cpu_s": c3 - c2, "compile_cpu_s": c4 - c3, "solve_cpu_s": c6 - c5,
        "build_over_solve_cpu": (c4 - c2) / (c6 - c5),
        "algorithm": algorithm, "engine": type(engine).__name__,
        "ipm_settings": ipm_settings if isinstance(engine, BlockIPM) else "",
        "kernels": ("numpy" if engine.block_kernels is None else "compiled") if isinstance(engine, BlockIPM) else "",
        "status": out.status.value,
        "multiplier": lam, "lp_iterations": out.iterations, "max_residual": residual, "message": out.message,
        "solve_cpu_s_per_iteration": (c6 - c5) / max(out.iterations, 1),
        "verified_1e-8": bool(out.status.is_success and residual <= 1e-8),
        "ordering": factoriser.ordering if factoriser else "", "factorisations": factoriser.factorisations if factoriser else 0,
        "factorisation": type(factoriser).__name__ if factoriser else "",
        "cholesky_fallbacks": engine.cholesky_fallbacks if isinstance(engine, BlockIPM) else 0,
        "solve_k_cpu_s": factoriser.solve_s if factoriser else 0.0,
        "k_solves": factoriser.solves if factoriser else 0,
        "krylov_steps": engine.krylov_steps if isinstance(engine, BlockIPM) else 0,
        "factorise_s": factoriser.factorise_s if factoriser else 0.0, "factor_nnz": factoriser.factor_nnz if factoriser else 0,
        "factor_processes": getattr(factoriser, "processes", 1) if factoriser else 0,
        "compiled_solves": bool(getattr(factoriser, "compiled_solves", False)),
        "compiled_factorisation": bool(getattr(factoriser, "compiled_factorisation", False)),
        # the worker process's CPU seconds through its latest factorisation (not in solve_cpu_s or the peak memory)
        "worker_cpu_s": getattr(factoriser, "worker_cpu_s", 0.0) if factoriser else 0.0,
        "peak_memory_mb": peak_memory_mb(),
    }


def _run_in_child(args: tuple) -> dict:
    return time_one(*args)


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="100,1000,10000")
    parser.add_argument("--algorithms", default="auto", help="comma-separated static-lp algorithms")
    parser.add_argument("--walls", default="", help="comma-separated CxB walls (courses x blocks per course)")
    parser.add_argument("--orderings", default="auto", help="block IPM orderings of K: auto, metis, mmd")
    parser.add_argument("--ipm-settings", default="default",
                        help="comma-separated block IPM settings: default, stationary, short_refinement, previous, ... (studies/lab/_ipm_settings.py)")
    parser.add_argument("--factorisations", default="auto",
                        help="comma-separated block IPM factorisations of K: auto, supernodal, superlu")
    parser.add_argument("--kernels", default="auto",
                        help="comma-separated block IPM per-interface kernels: auto, numpy, compiled (needs numba)")
    parser.add_argument("--factor-processes", default=None, choices=("auto", "1", "2"),
                        help="block IPM: processes for K's supernodal Cholesky in every run, over the settings' own "
                             "(1 reproduces the tables measured before the default became auto)")
    parser.add_argument("--compiled-solves", default=None, choices=("auto", "on", "off"),
                        help="block IPM: compiled solves with the supernodal Cholesky's factors in every run, over the "
                             "settings' own (off reproduces the compiled-kernel tables measured before they existed)")
    parser.add_argument("--compiled-factorisation", default=None, choices=("auto", "on", "off"),
                        help="block IPM: the supernodal Cholesky's factorisation by its compiled loop in every run, "
                             "over the settings' own (off reproduces the compiled-kernel tables measured before it "
                             "existed)")
    parser.add_argument("--time-limit", type=float, default=float("inf"), help="seconds per solve")
    parser.add_argument("--max-iterations", type=int, default=None,
                        help="block IPM iteration cap: measures the cost per iteration of a size too slow to finish")
    args = parser.parse_args(argv)
    walls = args.walls.split(",") if args.walls else args.sizes.split(",")
    for name in args.ipm_settings.split(","):  # a bad name: one line, before any run
        try:
            named_settings(name)
        except ValueError as error:
            parser.error(str(error))
    for wall in walls:
        if ":" in wall:  # options checked here (a plain size or CxB name is built in its own process)
            wall_or_size(wall)
    block = ("auto", "block-ipm")
    processes = None if args.factor_processes is None else (
        args.factor_processes if args.factor_processes == "auto" else int(args.factor_processes))
    choice = {None: None, "auto": "auto", "on": True, "off": False}
    solves, factorisation = choice[args.compiled_solves], choice[args.compiled_factorisation]
    cases = [(w, a, args.time_limit, o, args.max_iterations, st, fa, ke, processes, solves, factorisation) for w in walls for a in args.algorithms.split(",")
             for o in (args.orderings.split(",") if a in block else ["auto"])
             for st in (args.ipm_settings.split(",") if a in block else ["default"])
             for fa in (args.factorisations.split(",") if a in block else ["auto"])
             for ke in (args.kernels.split(",") if a in block else ["auto"])]
    context = multiprocessing.get_context("spawn")  # a fresh process per case: its own peak memory
    rows = []
    for case in cases:
        with context.Pool(1, maxtasksperchild=1) as pool:
            rows.append(pool.apply(_run_in_child, (case,)))
    keys = ["wall", "blocks", "algorithm", "ordering", "factorisation", "ipm_settings", "kernels", "k_solves", "factorise_s", "solve_k_cpu_s", "krylov_steps", "pyomo_build_cpu_s", "compile_cpu_s", "solve_cpu_s", "solve_s",
            "build_over_solve_cpu", "lp_iterations", "factorise_s", "peak_memory_mb", "status", "max_residual",
            "multiplier"]
    print(" ".join(f"{k:>13s}" for k in keys), flush=True)
    for r in rows:
        print(" ".join(f"{r[k]:>13.4g}" if isinstance(r[k], float) else f"{r[k]!s:>13s}" for k in keys))
    print()
    print("CPU times of the process (wall-clock solve in brackets; + the CPU of a factorisation worker process):")
    print("| free blocks | engine | ordering | factorisation of K | IPM settings | kernels | Pyomo build | compile | solve | iterations "
          "| factorisations, solves with K (CPU) | build + compile / solve | peak memory | verified 1e-8 | λ |")
    print("| ---: | --- | --- | --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: |")
    for r in rows:
        engine = ("block IPM" if r["engine"] in ("BlockIPM", "BlockLP") else r["algorithm"] if r["engine"] == "ClarabelLP"
                  else f"HiGHS {r['algorithm']}")
        kind = {"SupernodalCholesky": "supernodal Cholesky", "SymmetricFactoriser": "SuperLU"}.get(r["factorisation"], "–")
        named = f" ({r['wall']})" if ":" in r["wall"] else ""
        print(f"| {r['blocks']:,}{named} | {engine} | {r['ordering'] or '–'} | {kind} | {r['ipm_settings'] or '–'} | {r['kernels'] or '–'} "
              f"| {r['pyomo_build_cpu_s']:.2g} s | {r['compile_cpu_s']:.2g} s | **{r['solve_cpu_s']:.3g} s** ({r['solve_s']:.3g} s)"
              f"{f' + {w:.3g} s' if (w := r.get('worker_cpu_s', 0.0)) else ''} "
              f"| {r['lp_iterations']} | {r['factorise_s']:.3g} s, {r['k_solves']} in {r['solve_k_cpu_s']:.3g} s "
              f"| {r['build_over_solve_cpu']:.2f} "
              f"| {r['peak_memory_mb']:,.0f} MB | {'yes' if r['verified_1e-8'] else 'no'} ({r['max_residual']:.1e}) "
              f"| {r['multiplier']:.4f} |")
    print(f"wrote {write_csv(OUT / 'lp_timing.csv', rows)}")
    return rows


if __name__ == "__main__":
    main()

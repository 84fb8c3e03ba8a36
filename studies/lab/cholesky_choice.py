"""Which sparse factorisation for the block IPM's ``K``: orderings and packages side by side.

``K = A_B H^{-1} A_B^T`` (symmetric positive definite, 3 rows per free block) of a
running-bond wall's static LP, at a generic interior point (random ``s, y`` in
1e-3..1e3, so every entry of the structural pattern is nonzero, as in the IPM's later
iterations).  For each candidate: the ordering time (once per solve), one
factorisation of ``K`` (for the supernodal Cholesky also its numeric part alone, from ``K``'s values on the
structural pattern as the block IPM assembles them: *of which numeric*), one solve (CPU times of the process: comparable on a loaded machine; BLAS on one
thread, as the block IPM runs it, and MKL limited to one thread by ``MKL_NUM_THREADS=1`` for a fair
comparison), the nonzeros of the factors and the relative residual
``||K x - b|| / ||b||``.  Candidates that are not installed are skipped:

* ``supernodal-metis``, ``supernodal-mmd``: the block IPM's default
  (:class:`blockmpec.solvers.linalg.cholesky.SupernodalCholesky`, a multifrontal Cholesky
  on scipy's LAPACK/BLAS; the ordering column includes its symbolic analysis);
* ``superlu-mmd``, ``superlu-metis``: :class:`~blockmpec.solvers.linalg.cholesky.SymmetricFactoriser`
  (scipy's SuperLU, natural order after a symmetric permutation from the
  structural pattern; METIS via ``pymetis``), the fallback;
* ``superlu-colamd``: SuperLU's own column ordering, with its partial-pivoting defaults
  relaxed to symmetric mode, for reference;
* ``qdldl`` (``pip install qdldl``, Apache-2.0): LDL^T with AMD;
* ``cholmod`` (``pip install sksparse-minimal``): CHOLMOD, whose Supernodal module
  (bundled in that wheel) is GPL, so never a default dependency;
* ``pardiso`` (``pip install pypardiso``, Intel MKL, Intel Simplified Software
  License): supernodal Cholesky (``mtype=2``) with numeric refactorisation;
* ``supernodal-compiled`` (numba installed): the default's factorisation and solves by the compiled loops over
  supernodes that call the same LAPACK and BLAS routines (``compiled_factorisation`` and ``compiled_solves``,
  :mod:`blockmpec.solvers.linalg.cholesky_kernels`; what the block IPM runs with compiled kernels): the same
  factors and solutions bit for bit, without the Python loop's cost per supernode;
* ``supernodal-numba`` (``pip install numba``, BSD-2; not a dependency of blockmpec): the default's
  factorisation, its solve compiled instead of a Python loop over supernodes calling BLAS (the
  panels packed into one array after the factorisation, not timed; forward substitution by
  columns with the rows below gathered, backward by dot products).  Asks whether the loop's
  per-supernode overhead is what a solve costs: it is not.  ``--walls 100x100`` and ``--walls 316x316``
  ``--methods supernodal-metis,supernodal-numba`` (one run each, CPU s per solve; the 100k run with the
  other core busy): 10,050 blocks 0.010 (loop) against 0.013 s (compiled), 100,014 blocks 0.133 against
  0.165 s, the same residuals (1e-10, 3e-10 / 4e-10).  Each solve reads the factor twice, so it is bound by
  memory, as every library's solve is (table in the README), and the BLAS loop reads it faster.  The table gives
  the rate at which each solve reads the factor (``solve_read_gb_s``) beside the rate of a plain copy of a
  400 MB array in the same process (``copy_read_gb_s``, :func:`copy_rate`).

Usage::

    python studies/lab/cholesky_choice.py [--walls 100x100,316x316] [--methods ...] [--blas-threads 1,2]
                                      [--extend-add-runs 2,8] [--side-by-side [--rounds 5]]

``--blas-threads 1,2`` measures each method with one and with two BLAS threads (wall and CPU side by side;
for the supernodal Cholesky only its fronts of at least ``threaded_front_rows`` rows get them, whose
dense updates are BLAS-3: multithreaded BLAS on every front spins its threads between tiny calls).
``--extend-add-runs 2,8`` measures the supernodal Cholesky with each ``extend_add_runs`` (children whose rows
fall into at most that many runs of their parent's rows are added by slices, the others by a flat index) and
reports the flat indices' memory.

``--side-by-side`` asks whether the supernodal factorisation can use two cores.  Its elimination tree is split
into two unions of whole subtrees of about equal estimated cost (``SupernodalCholesky.subtree_halves``) and
their common ancestors (the top).  Each half is factorised by a worker process, alone and then with the other
worker at the same time; the top runs after both.  Processes, not threads: scipy's LAPACK wrappers and each
front's numpy work hold the GIL.  So ``top + max(halves side by side)`` bounds what any two-core factorisation
of this tree could take.  Writes ``side_by_side.csv``.

Writes ``studies/output/cholesky_choice/cholesky_choice.csv``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from threadpoolctl import threadpool_limits

import blockmpec as bm
from blockmpec.formulations import compile_linear, pause_gc, static_lp
from blockmpec.solvers.engines.lp_engine import cold_lp_engine
from blockmpec.solvers.engines.scaling import LoadUnits
from blockmpec.solvers.linalg.block_ipm import IPMIterate, compiled_kernels_available
from blockmpec.solvers.linalg.cholesky import (
    SupernodalCholesky,
    SymmetricFactoriser,
    metis_available,
    structural_pattern,
)

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _tables import write_csv  # noqa: E402
from _walls import wall_shape  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "cholesky_choice"
#: our factorisers of K, by the first part of a method name (the second part is the ordering)
FACTORISERS = {"supernodal": SupernodalCholesky, "superlu": SymmetricFactoriser}
METHODS = ("supernodal-metis", "supernodal-mmd", "superlu-mmd", "superlu-metis", "superlu-colamd", "qdldl", "cholmod", "pardiso",
           "supernodal-numba", "supernodal-compiled")
LICENCE = {
    "supernodal-metis": "BSD-3 (scipy) + MIT/Apache-2.0 (pymetis)", "supernodal-mmd": "BSD-3 (scipy)",
    "superlu-mmd": "BSD-3 (scipy)", "superlu-metis": "BSD-3 (scipy) + MIT/Apache-2.0 (pymetis)",
    "superlu-colamd": "BSD-3 (scipy)", "qdldl": "Apache-2.0", "cholmod": "GPL (Supernodal) + LGPL, bundled",
    "pardiso": "Intel Simplified Software License (proprietary)",
    "supernodal-numba": "BSD-3 (ours, scipy) + BSD-2 (numba)",
    "supernodal-compiled": "BSD-3 (ours, scipy) + BSD-2 (numba)",
}


def reduced_matrix(courses: int, per_course: int, seed: int = 0):
    """``(K, engine)`` at a random interior point of the wall's static LP in load units."""
    ops = bm.assemble(bm.cases.wall(courses=courses, blocks_per_course=per_course))
    lp = compile_linear(pause_gc(static_lp)(ops))
    engine = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
    rng = np.random.default_rng(seed)
    p = engine.h.size
    it = IPMIterate(np.zeros(engine.c.size), 10.0 ** rng.uniform(-3, 3, p), np.zeros(engine.b.size),
                    10.0 ** rng.uniform(-3, 3, p))
    K, _ = engine.reduced_matrix(it)
    return sp.csc_array(K), engine


def compiled_solver(f: SupernodalCholesky, K: sp.csc_array):
    """``solve(rhs)`` of ``f``'s factors of ``K`` by one compiled (numba) pass per triangle; None without numba.

    The panels ``[L11; L21]`` of every supernode are packed column-major into one array (after the
    factorisation, not timed); forward substitution runs by columns (the rows below accumulated in a
    buffer, then scattered), backward by dot products against the gathered rows below."""
    try:
        import numba
    except ImportError:
        return None
    captured = {}

    class Capturing(SupernodalCholesky):
        def solver(self, diagonal_blocks, below_blocks):
            captured["blocks"] = diagonal_blocks, below_blocks
            return super().solver(diagonal_blocks, below_blocks)

    f.__class__ = Capturing
    f.factorise(K)
    f.__class__ = SupernodalCholesky
    diagonal_blocks, below_blocks = captured["blocks"]
    widths = (f.end - f.first).astype(np.int64)
    heights = np.array([0 if b is None else b.shape[0] for b in below_blocks], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum((widths + heights) * widths)]).astype(np.int64)
    panels = np.empty(offsets[-1])
    for s, (L11, L21) in enumerate(zip(diagonal_blocks, below_blocks)):
        w = int(widths[s])
        panel = panels[offsets[s]:offsets[s + 1]].reshape(w, -1).T  # column-major (w + h) x w view
        panel[:w] = np.tril(L11)
        if L21 is not None:
            panel[w:] = L21
    below = np.concatenate(f.below_rows).astype(np.int64)
    below_offsets = np.concatenate([[0], np.cumsum(heights)]).astype(np.int64)
    kernel = _compiled_kernel(numba)
    first = f.first.astype(np.int64)

    def solve(rhs):
        x = np.ascontiguousarray(rhs[f.perm], dtype=float)
        kernel(panels, offsets, first, widths, below, below_offsets, x)
        return x[f.inverse_perm]

    solve(np.zeros(f.n))  # compile outside the timing
    return solve


def _compiled_kernel(numba):
    @numba.njit(boundscheck=False)
    def substitute(panels, offsets, first, widths, below, below_offsets, x):
        buffer = np.empty(x.size)
        for s in range(first.size):  # L~ y = P rhs
            f, w, b0 = first[s], widths[s], below_offsets[s]
            h = below_offsets[s + 1] - b0
            m = w + h
            buffer[:h] = 0.0
            for j in range(w):
                column = offsets[s] + j * m
                xj = x[f + j] / panels[column + j]
                x[f + j] = xj
                for i in range(j + 1, w):
                    x[f + i] -= panels[column + i] * xj
                for i in range(h):
                    buffer[i] += panels[column + w + i] * xj
            for i in range(h):
                x[below[b0 + i]] -= buffer[i]
        for s in range(first.size - 1, -1, -1):  # L~^T z = y
            f, w, b0 = first[s], widths[s], below_offsets[s]
            h = below_offsets[s + 1] - b0
            m = w + h
            for i in range(h):
                buffer[i] = x[below[b0 + i]]
            for j in range(w - 1, -1, -1):
                column = offsets[s] + j * m
                total = x[f + j]
                for i in range(j + 1, w):
                    total -= panels[column + i] * x[f + i]
                for i in range(h):
                    total -= panels[column + w + i] * buffer[i]
                x[f + j] = total / panels[column + j]

    return substitute


def measure(method: str, K: sp.csc_array, engine, threads: int = 1, extend_add_runs: int | None = None) -> dict | None:
    """Ordering, one factorisation and one solve of ``K x = b`` by ``method``; None if not installed.

    ``threads``: BLAS threads of the supernodal Cholesky's large fronts (``front_threads``; the rest of
    the process on one), or of the whole factorisation for the other methods.  ``extend_add_runs``: the
    supernodal Cholesky's ``extend_add_runs`` (None: its default)."""
    n = K.shape[0]
    b = np.random.default_rng(1).standard_normal(n)
    t_order = 0.0
    t_values = w_values = None
    kind, _, ordering = method.partition("-")
    # supernodal-metis, its factorisation and solves compiled (calling the same LAPACK and BLAS)
    compiled = method == "supernodal-compiled"
    if compiled:
        if not compiled_kernels_available():
            return None
        ordering = "metis"
    if method == "supernodal-numba":
        if not metis_available():
            return None
        t = time.process_time()
        f = SupernodalCholesky(structural_pattern(engine.A_B, engine.k), "metis")
        t_order = time.process_time() - t
        f.factorise(K)
        t, w = time.process_time(), time.perf_counter()
        f.factorise(K)
        t_factor, w_factor = time.process_time() - t, time.perf_counter() - w
        solve, nnz = compiled_solver(f, K), f.factor_nnz
        if solve is None:
            return None
    elif kind in FACTORISERS and ordering in ("metis", "mmd"):
        if ordering == "metis" and not metis_available():
            return None
        t, w = time.process_time(), time.perf_counter()
        extra = {} if kind != "supernodal" or extend_add_runs is None else {"extend_add_runs": extend_add_runs}
        f = FACTORISERS[kind](structural_pattern(engine.A_B, engine.k), ordering, **extra)
        if kind == "supernodal":
            f.front_threads = threads
            f.compiled_solves = f.compiled_factorisation = compiled
        t_order = time.process_time() - t
        # the first numeric factorisation allocates (supernodal); time the second.  Its solve loads the compiled
        # loops (numba's import and cache) before any is timed
        f.factorise(K)(b)
        t, w = time.process_time(), time.perf_counter()
        solve = f.factorise(K)
        t_factor, w_factor = time.process_time() - t, time.perf_counter() - w
        nnz = f.factor_nnz
        if kind == "supernodal":  # the numeric factorisation alone, from K's values on the pattern (as the IPM's)
            values = f.pattern_values(K)
            del solve
            t, w = time.process_time(), time.perf_counter()
            solve = f.factorise_values(values)
            t_values, w_values = time.process_time() - t, time.perf_counter() - w
    elif method == "superlu-colamd":
        t, w = time.process_time(), time.perf_counter()
        lu = spla.splu(sp.csc_matrix(K), permc_spec="COLAMD", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
        t_factor, w_factor = time.process_time() - t, time.perf_counter() - w
        solve, nnz = lu.solve, lu.nnz
    elif method == "qdldl":
        try:
            import qdldl
        except ImportError:
            return None
        t, w = time.process_time(), time.perf_counter()
        solver = qdldl.Solver(sp.csc_matrix(K))
        t_factor, w_factor = time.process_time() - t, time.perf_counter() - w
        solve, nnz = solver.solve, 2 * solver.factors()[0].nnz + n
    elif method == "cholmod":
        try:
            from sksparse_minimal import SparseCholesky
        except ImportError:
            return None
        t, w = time.process_time(), time.perf_counter()
        factor = SparseCholesky(sp.csc_matrix(K))
        t_factor, w_factor = time.process_time() - t, time.perf_counter() - w
        solve, nnz = factor.solve_A, 0
    elif method == "pardiso":
        try:
            import pypardiso
        except (ImportError, OSError):
            return None
        solver = pypardiso.PyPardisoSolver(mtype=2)  # real symmetric positive definite
        upper = sp.triu(K, format="csr")
        upper.sort_indices()
        t, w = time.process_time(), time.perf_counter()
        solver.factorize(upper)
        t_factor, w_factor = time.process_time() - t, time.perf_counter() - w

        def solve(rhs):
            return solver.solve(upper, rhs)

        nnz = 2 * int(solver.iparm[17])
    else:
        raise ValueError(f"unknown method {method!r}; use one of {', '.join(METHODS)}")
    t, w = time.process_time(), time.perf_counter()
    for _ in range(5):
        x = solve(b)
    t_solve, w_solve = (time.process_time() - t) / 5, (time.perf_counter() - w) / 5
    residual = float(np.linalg.norm(K @ x - b) / np.linalg.norm(b))
    runs = f.extend_add_runs if kind == "supernodal" else None
    index_mb = f.extend_add_index_bytes / 1e6 if kind == "supernodal" else None
    return {"method": method, "extend_add_runs": runs, "extend_add_index_mb": index_mb,
            "rows": n, "nnz_K": K.nnz, "order_s": t_order, "factor_s": t_factor, "solve_s": t_solve,
            "factor_wall_s": w_factor, "solve_wall_s": w_solve,
            # supernodal: the factorisation from K's values on its pattern (factor_s also gathers them from K)
            "factor_values_s": t_values, "factor_values_wall_s": w_values,
            "factor_nnz": nnz, "residual": residual, "licence": LICENCE[method],
            # the supernodal factorisation's dense work (multiply-adds), the same for every implementation of it
            "factor_gflop": f.factor_flops / 1e9 if kind == "supernodal" else None,
            # a solve reads the factor twice (forward and backward): the rate at which it does, bytes per second
            "solve_read_gb_s": 2 * 8 * nnz / w_solve / 1e9 if nnz else None}


def copy_rate(megabytes: int = 400, rounds: int = 5) -> float:
    """GB/s that a plain copy of a ``megabytes`` array reads (its best of ``rounds``): what memory gives one
    process, to set beside a solve's read rate (``solve_read_gb_s``)."""
    source = np.ones(megabytes * 1_000_000 // 8)
    target = np.empty_like(source)
    best = float("inf")
    for _ in range(rounds):
        t = time.perf_counter()
        np.copyto(target, source)
        best = min(best, time.perf_counter() - t)
    return source.nbytes / best / 1e9


def _half_worker(connection, f: SupernodalCholesky, values: np.ndarray, halves: list[np.ndarray]) -> None:
    """Worker process: factorise the half whose index arrives, answer ``(wall s, CPU s, factorised)``; stop on None."""
    with threadpool_limits(limits=1, user_api="blas"):
        while (g := connection.recv()) is not None:
            blocks: list = [None] * f.supernodes
            t, c = time.perf_counter(), time.process_time()
            ok = f.factor_supernodes(halves[g].tolist(), values, {}, blocks, list(blocks))
            connection.send((time.perf_counter() - t, time.process_time() - c, ok))


def _answer(connection) -> float:
    """A worker's wall-clock time for its half (a half that is not positive definite stops the study)."""
    wall, _, factorised = connection.recv()
    if not factorised:
        raise RuntimeError("side by side: a half of K is not positive definite; its time measures nothing")
    return wall


def side_by_side(K: sp.csc_array, engine, rounds: int = 5) -> dict:
    """Times of the supernodal factorisation of ``K``: whole and its two halves
    (:meth:`~blockmpec.solvers.linalg.cholesky.SupernodalCholesky.subtree_halves`) in this process, the top
    after them, the halves alone and side by side in two worker processes (medians of ``rounds``, wall-clock s).  ``speedup`` = (top + both halves alone) / (top + the slower half side by side)."""
    import multiprocessing

    f = SupernodalCholesky(structural_pattern(engine.A_B, engine.k), "metis")
    halves, top = f.subtree_halves()
    values = f.pattern_values(K)
    context = multiprocessing.get_context("fork")  # the workers share f and K's values with this process
    pipes = [context.Pipe() for _ in halves]
    workers = [context.Process(target=_half_worker, args=(child, f, values, halves)) for _, child in pipes]
    for w in workers:
        w.start()
    whole, pieces, top_s, alone, together = [], [], [], [[], []], [[], []]
    with threadpool_limits(limits=1, user_api="blas"):
        for _ in range(rounds):
            t = time.perf_counter()
            f.factorise_values(values)
            whole.append(time.perf_counter() - t)
            blocks: list = [None] * f.supernodes
            updates: dict = {}
            t = time.perf_counter()
            for half in halves:  # the top's children's updates, then the top alone
                f.factor_supernodes(half.tolist(), values, updates, blocks, list(blocks))
            pieces.append(time.perf_counter() - t)
            t = time.perf_counter()
            f.factor_supernodes(top.tolist(), values, updates, blocks, list(blocks))
            top_s.append(time.perf_counter() - t)
            for g, (parent, _) in enumerate(pipes):
                parent.send(g)
                alone[g].append(_answer(parent))
            for g, (parent, _) in enumerate(pipes):
                parent.send(g)
            for g, (parent, _) in enumerate(pipes):
                together[g].append(_answer(parent))
    for parent, _ in pipes:
        parent.send(None)
    for w in workers:
        w.join()
    cost = f.front_costs()
    med = [float(np.median(x)) for x in (whole, pieces, top_s, *alone, *together)]
    one_core = med[2] + med[3] + med[4]  # the top and both halves one after the other, in the workers
    bound = med[2] + max(med[5], med[6])
    return {"blocks": K.shape[0] // 3, "supernodes": f.supernodes, "half_supernodes": "/".join(str(h.size) for h in halves),
            "top_supernodes": int(top.size), "estimated_s": "/".join(f"{cost[h].sum():.3f}" for h in (*halves, top)),
            "whole_s": med[0], "halves_here_s": med[1], "top_s": med[2], "alone_0_s": med[3], "alone_1_s": med[4],
            "side_by_side_0_s": med[5], "side_by_side_1_s": med[6], "one_core_s": one_core, "two_core_bound_s": bound,
            "speedup": one_core / bound, "rounds": rounds}


def smoke() -> None:
    """The smallest runs, checked (CI): on a 6x8 wall the default method, the SuperLU fallback and (numba installed)
    the compiled solve solve ``K x = b`` to round-off, with the rates as documented; ``--side-by-side`` on a 12x16
    wall: both workers answer every round and the supernodes it reports add up to the whole tree."""
    failures = []
    K, engine = reduced_matrix(6, 8)
    for method in ("supernodal-metis", "superlu-mmd", "supernodal-numba"):
        row = measure(method, K, engine)
        if row is None:
            if method != "supernodal-numba":  # numba (or pymetis) not installed: skipped, as the study says
                failures.append(f"{method}: not measured")
            continue
        if not (row["residual"] <= 1e-10 and row["rows"] == K.shape[0] and row["solve_s"] > 0):
            failures.append(f"{method}: residual {row['residual']:.1e}, rows {row['rows']}, solve {row['solve_s']}")
        # the factor's two reads per solve, as a rate: bytes of both reads over the solve's wall-clock
        if not math.isclose(row["solve_read_gb_s"], 16 * row["factor_nnz"] / row["solve_wall_s"] / 1e9, rel_tol=1e-6):
            failures.append(f"{method}: solve_read_gb_s is not the factor's two reads over the solve's time")
        if (row["factor_gflop"] is None) != (not method.startswith("supernodal")):
            failures.append(f"{method}: factor_gflop {row['factor_gflop']}")
    if not copy_rate(megabytes=8, rounds=2) > 0:
        failures.append("copy_rate is not positive")
    row = side_by_side(*reduced_matrix(12, 16), rounds=2)
    halves = [int(v) for v in row["half_supernodes"].split("/")]
    if not (sum(halves) + row["top_supernodes"] == row["supernodes"] and min(halves) > 0):
        failures.append(f"side by side: supernodes {row['half_supernodes']} + {row['top_supernodes']} != "
                        f"{row['supernodes']}")
    times = [row[f"{key}_{half}_s"] for key in ("alone", "side_by_side") for half in (0, 1)]
    if not (all(t > 0 for t in times) and row["two_core_bound_s"] > 0 and row["speedup"] > 0):
        failures.append(f"side by side: times {times}, bound {row['two_core_bound_s']}, speed-up {row['speedup']}")
    for line in failures:
        print(f"smoke check failed: {line}")
    if failures:
        raise SystemExit(1)
    print("smoke: every method measured solves K x = b to round-off; the side-by-side halves add up")


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walls", default="100x100", help="comma-separated CxB walls (courses x blocks per course)")
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--blas-threads", default="1", help="comma-separated BLAS thread counts, each measured")
    parser.add_argument("--extend-add-runs", default="",
                        help="comma-separated extend_add_runs of the supernodal Cholesky, each measured (default: its own)")
    parser.add_argument("--side-by-side", action="store_true",
                        help="time the supernodal factorisation's two subtree halves alone and in two processes at once")
    parser.add_argument("--rounds", type=int, default=5, help="--side-by-side: rounds (medians are reported)")
    parser.add_argument("--smoke", action="store_true", help="the smallest runs, with their checks (CI)")
    args = parser.parse_args(argv)
    if args.smoke:
        smoke()
        return []
    if args.side_by_side:
        rows = []
        for wall in args.walls.split(","):
            rows.append(side_by_side(*reduced_matrix(*wall_shape(wall)), rounds=args.rounds))
            print(rows[-1], flush=True)
        print("| free blocks | supernodes (halves / top) | whole (halves + top here) | halves alone | top "
              "| halves side by side | top + slower half side by side | speed-up bound |")
        print("| ---: | --- | --- | --- | ---: | --- | ---: | ---: |")
        for r in rows:
            print(f"| {r['blocks']:,} | {r['supernodes']:,} ({r['half_supernodes']} / {r['top_supernodes']}) "
                  f"| {r['whole_s']:.3f} s ({r['halves_here_s']:.3f} + {r['top_s']:.3f} s) | {r['alone_0_s']:.3f} / {r['alone_1_s']:.3f} s "
                  f"| {r['top_s']:.3f} s | {r['side_by_side_0_s']:.3f} / {r['side_by_side_1_s']:.3f} s | {r['two_core_bound_s']:.3f} s | {r['speedup']:.2f}x |")
        print(f"wrote {write_csv(OUT / 'side_by_side.csv', rows)}")
        return rows
    rows = []
    copy_gb_s = copy_rate()
    for wall in args.walls.split(","):
        courses, per = wall_shape(wall)
        K, engine = reduced_matrix(courses, per)
        for method in args.methods.split(","):
            runs_values = [None]
            if method.startswith("supernodal") and args.extend_add_runs:
                runs_values = [int(v) for v in args.extend_add_runs.split(",")]
            for threads, runs in ((t, r) for t in (int(v) for v in args.blas_threads.split(",")) for r in runs_values):
                # one thread as the block IPM runs (multithreaded BLAS spins on small calls); the supernodal
                # Cholesky gives its large fronts `threads` (front_threads), the other methods get them throughout
                own = 1 if method.startswith("supernodal") else threads
                with threadpool_limits(limits=own, user_api="blas"):
                    row = measure(method, K, engine, threads, runs)
                if row is None:
                    print(f"{method}: not installed, skipped", flush=True)
                    break
                row["blocks"] = K.shape[0] // 3  # free blocks: 3 equilibrium rows each
                row["blas_threads"] = threads
                row["copy_read_gb_s"] = copy_gb_s
                rows.append(row)
                print(row, flush=True)
    print()
    print(f"CPU times (wall-clock in brackets); the solve reads the factor twice, at the rate given (a plain copy in "
          f"this process reads {copy_gb_s:.1f} GB/s):")
    print("| blocks | rows of K | method | licence | BLAS threads | extend-add runs (index) | ordering | factorisation "
          "| of which numeric | solve (factor read at) | nonzeros of factors | dense work of a factorisation "
          "| residual |")
    print("| ---: | ---: | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in rows:
        nnz = f"{r['factor_nnz'] / 1e6:.1f}M" if r["factor_nnz"] else "–"
        runs = "–" if r["extend_add_runs"] is None else f"{r['extend_add_runs']} ({r['extend_add_index_mb']:.0f} MB)"
        rate = f", {r['solve_read_gb_s']:.1f} GB/s" if r["solve_read_gb_s"] else ""
        numeric = ("–" if r["factor_values_s"] is None
                   else f"{r['factor_values_s']:.2f} s ({r['factor_values_wall_s']:.2f} s)")
        print(f"| {r['blocks']:,} | {r['rows']:,} | {r['method']} | {r['licence']} | {r['blas_threads']} | {runs} "
              f"| {r['order_s']:.2f} s | {r['factor_s']:.2f} s ({r['factor_wall_s']:.2f} s) | {numeric} "
              f"| {r['solve_s']:.3f} s ({r['solve_wall_s']:.3f} s{rate}) | {nnz} "
              f"| {'–' if r['factor_gflop'] is None else format(r['factor_gflop'], '.2f') + ' GFlop'} "
              f"| {r['residual']:.0e} |")
    if rows:
        print(f"wrote {write_csv(OUT / 'cholesky_choice.csv', rows)}")
    return rows


if __name__ == "__main__":
    main()

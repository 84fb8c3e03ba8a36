"""The supernodal Cholesky of the block IPM's matrix K: symbolic structure, factors and solves.

The symbolic factorisation is checked against dense elimination on small random patterns; the
numeric one by residuals against the matrix itself and against SuperLU on the same ordering; the
amalgamated supernodes hold every structural nonzero only if these residuals stay at round-off.
"""

import dataclasses
import os
import sys
import time

import numpy as np
import pytest
import scipy.sparse as sp

import blockmpec as bm
from blockmpec.formulations import compile_linear, static_lp
from blockmpec.solvers.engines.block_lp import BlockLP
from blockmpec.solvers.engines.lp_engine import cold_lp_engine
from blockmpec.solvers.engines.scaling import LoadUnits
from blockmpec.solvers.linalg.block_ipm import IPMIterate, single_blas_thread
from blockmpec.solvers.linalg.cholesky import (
    SupernodalCholesky,
    SymmetricFactoriser,
    column_structures,
    structural_pattern,
)
from blockmpec.solvers.plan import BLOCK_IPM_RULES
from helpers import solve_with


def _random_pattern(n: int, density: float, seed: int) -> sp.csc_array:
    rng = np.random.default_rng(seed)
    upper = sp.random_array((n, n), density=density, rng=rng, format="csc")
    P = (upper + upper.T + sp.eye_array(n)).tocsc()
    return sp.csc_array((np.ones(P.nnz), P.indices, P.indptr), shape=P.shape)


def _dense_symbolic(pattern: np.ndarray) -> list[set]:
    """Rows of each column of L by elimination on booleans (no cancellation)."""
    filled = pattern.astype(bool).copy()
    n = filled.shape[0]
    for j in range(n):
        below = np.flatnonzero(filled[j + 1:, j]) + j + 1
        filled[np.ix_(below, below)] = True
    return [set(np.flatnonzero(filled[j:, j]) + j) for j in range(n)]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_column_structures_match_dense_elimination(seed):
    P = _random_pattern(60, 0.04, seed)
    structure, parent = column_structures(sp.tril(P, format="csc"))
    expected = _dense_symbolic(P.toarray())
    assert [set(rows.tolist()) for rows in structure] == expected
    for j, rows in enumerate(structure):
        assert rows[0] == j and np.all(np.diff(rows) > 0)
        assert parent[j] == (rows[1] if rows.size > 1 else -1)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_symbolic_factorisation_matches_the_python_loop(seed):
    """Counts, elimination tree and the rows of chosen columns, compiled (row subtrees) and by the Python loop."""
    pytest.importorskip("numba")
    from blockmpec.solvers.linalg.cholesky_kernels import symbolic_factorisation

    for n, density in ((60, 0.04), (300, 0.01), (200, 0.0)):
        lower = sp.tril(_random_pattern(n, density, seed), format="csc")
        structure, parent = column_structures(lower)
        counts, compiled_parent, rows_of = symbolic_factorisation(lower)
        assert np.array_equal(compiled_parent, parent)
        assert np.array_equal(counts, [rows.size for rows in structure])
        columns = np.random.default_rng(seed).choice(n, size=n // 3, replace=False)
        for j, rows in zip(columns.tolist(), rows_of(columns)):
            assert np.array_equal(rows, structure[j])


def test_compiled_symbolic_analysis_gives_the_same_supernodes(wall_K):
    """A whole analysis with the compiled and the Python symbolic factorisation: the same supernodes, rows and
    assembly (so the same factors)."""
    pytest.importorskip("numba")
    _, pattern = wall_K
    python = SupernodalCholesky(pattern, "mmd", compiled_symbolic=False)
    compiled = SupernodalCholesky(pattern, "mmd", compiled_symbolic=True)
    assert compiled.compiled_symbolic and not python.compiled_symbolic
    assert np.array_equal(compiled.perm, python.perm)
    assert np.array_equal(compiled.first, python.first) and np.array_equal(compiled.end, python.end)
    assert all(np.array_equal(a, b) for a, b in zip(compiled.rows, python.rows))
    assert np.array_equal(compiled.assembly_destination, python.assembly_destination)


def _reduced_K(courses: int, per_course: int, seed: int):
    """``(K, pattern)``: ``K`` of a running-bond wall's static LP (load units) at a random interior point (every
    structural entry nonzero), and its structural pattern."""
    ops = bm.assemble(bm.cases.wall(courses, per_course))
    lp = compile_linear(static_lp(ops))
    engine = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
    rng = np.random.default_rng(seed)
    p = engine.h.size
    it = IPMIterate(np.zeros(engine.c.size), 10.0 ** rng.uniform(-3, 3, p), np.zeros(engine.b.size),
                    10.0 ** rng.uniform(-3, 3, p))
    K, _ = engine.reduced_matrix(it)
    return sp.csc_array(K), structural_pattern(engine.A_B, engine.k)


@pytest.fixture(scope="module")
def wall_K():
    """K of a 15x30 wall's static LP at a generic interior point (every structural entry nonzero)."""
    return _reduced_K(15, 30, seed=3)


@pytest.mark.parametrize("ordering", ["metis", "mmd"])
@pytest.mark.parametrize("relax", [0.0, 1.0, 4.0])
def test_supernodal_cholesky_solves_K_to_round_off(wall_K, ordering, relax):
    from blockmpec.solvers.linalg.cholesky import metis_available

    if ordering == "metis" and not metis_available():
        pytest.skip("pymetis not installed")
    K, pattern = wall_K
    chol = SupernodalCholesky(pattern, ordering, relax=relax)
    solve = chol.factorise(K)
    rng = np.random.default_rng(0)
    b = rng.standard_normal(K.shape[0])
    x = solve(b)
    assert np.linalg.norm(K @ x - b) <= 1e-9 * np.linalg.norm(b)
    lu = SymmetricFactoriser(pattern, ordering, perm=chol.perm).factorise(K)
    y = lu(b)
    assert np.linalg.norm(x - y) <= 1e-8 * np.linalg.norm(y)
    B = np.stack([b, rng.standard_normal(b.size)], axis=1)  # several right-hand sides at once
    X = solve(B)
    assert np.allclose(X[:, 0], x, rtol=0, atol=1e-12 * np.abs(x).max())
    assert np.linalg.norm(K @ X[:, 1] - B[:, 1]) <= 1e-8 * np.linalg.norm(B[:, 1])
    # fill: the structural nonzeros of L (+ U, as SuperLU counts them) are SuperLU's, amalgamation aside
    fresh = SymmetricFactoriser(pattern, ordering, perm=chol.perm)
    fresh.factorise(K)
    assert chol.factor_nnz <= 1.01 * fresh.factor_nnz
    assert chol.stored_nnz >= chol.factor_nnz // 2
    if relax > 0:
        assert chol.supernodes < 0.5 * K.shape[0] / 3  # merged beyond one block (3 rows) per supernode


def test_supernodal_cholesky_reports_an_indefinite_matrix(wall_K):
    K, pattern = wall_K
    chol = SupernodalCholesky(pattern, "mmd")
    indefinite = sp.csc_array(K - 2.0 * sp.diags_array(K.diagonal()))
    assert chol.factorise(indefinite) is None
    assert chol.factorise(K) is not None


def test_supernodal_cholesky_rejects_entries_outside_the_pattern(wall_K):
    K, pattern = wall_K
    chol = SupernodalCholesky(pattern, "mmd")
    outside = sp.lil_array(K.shape)
    outside[0, K.shape[0] - 1] = outside[K.shape[0] - 1, 0] = 1e-3
    with pytest.raises(ValueError, match="outside its structural pattern"):
        chol.factorise(sp.csc_array(K + outside))


def _supernodal_on_any_size(monkeypatch) -> None:
    """The LP engines' ``factorisation="auto"`` takes the supernodal Cholesky on any size of ``K`` (the plan's
    :data:`~blockmpec.solvers.plan.BLOCK_IPM_RULES` with ``supernodal_rows`` 0; its other thresholds kept)."""
    from blockmpec.solvers import plan

    monkeypatch.setattr(plan, "BLOCK_IPM_RULES", dataclasses.replace(plan.BLOCK_IPM_RULES, supernodal_rows=0))


def _worker_ready_at_once(monkeypatch) -> None:
    """Every two-process factorisation waits for its worker's set-up (in a solve it starts in the background, and a
    small wall's solve may end before the worker is ready)."""
    start = SupernodalCholesky.start_worker
    monkeypatch.setattr(SupernodalCholesky, "start_worker", lambda self, wait=False: start(self, wait=True))


@pytest.mark.slow
def test_block_ipm_same_lambda_with_either_factorisation(monkeypatch):
    """The supernodal Cholesky (default), the same with a worker process (``factor_processes`` 2) and SuperLU's
    LDL^T give the same optimum, all verified; the worker process ends with the solve."""
    from blockmpec.solvers.engines.highs import static_lp_solution

    _worker_ready_at_once(monkeypatch)

    ops = bm.assemble(bm.cases.wall(10, 20))
    lp = compile_linear(static_lp(ops))
    lams = {}
    for factorisation, processes in (("supernodal", 1), ("supernodal", 2), ("superlu", 1)):
        engine = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
        engine.factorisation = factorisation
        engine.settings(factor_processes=processes)
        out = engine.solve()
        assert out.status is bm.Status.OPTIMAL
        assert isinstance(engine.factoriser, SupernodalCholesky if factorisation == "supernodal" else SymmetricFactoriser)
        assert max(bm.verify.residuals(ops, static_lp_solution(lp, out), associative=True).values()) <= 1e-8
        if processes == 2:
            assert engine.factoriser.processes == 2 and engine.factoriser.worker is None  # closed by the solve
            assert engine.factoriser.worker_factorisations == engine.factoriser.factorisations > 0
        lams[factorisation, processes] = float(lp.values("lam", out.v)[0])
    reference = lams["superlu", 1]
    assert all(abs(lam - reference) <= 1e-8 * abs(reference) for lam in lams.values()), lams


def test_block_ipm_unknown_factorisation_is_one_clear_error():
    ops = bm.assemble(bm.cases.wall(3, 4))
    lp = compile_linear(static_lp(ops))
    engine = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
    assert isinstance(engine, BlockLP)
    engine.factorisation = "cholmod"
    with pytest.raises(ValueError, match="unknown factorisation 'cholmod'"):
        engine.factoriser


def test_subtree_halves_factorised_apart_give_the_same_factors():
    """``studies/lab/cholesky_choice.py --side-by-side`` times two unions of subtrees of the elimination tree factorised
    in two processes (:meth:`SupernodalCholesky.subtree_halves`).  That is only a bound on a two-core factorisation if
    the split is one: every supernode is in exactly one half or in the top, no half holds a child of the other's or of
    the top's supernodes, and the halves factorised apart (each with its own updates), then the top, give the whole
    factorisation's factors bit for bit."""
    K, pattern = _reduced_K(12, 16, seed=0)
    f = SupernodalCholesky(pattern, "metis")
    halves, top = f.subtree_halves()
    assert all(h.size for h in halves) and top.size
    owner = np.full(f.supernodes, -1)
    for g, half in enumerate(halves):
        owner[half] = g
    assert np.array_equal(np.sort(np.concatenate([*halves, top])), np.arange(f.supernodes))
    for s, kids in enumerate(f.children):
        for c in kids:
            assert owner[s] == -1 or owner[c] == owner[s], (s, c)  # a half's supernode has only its half's children
    whole: list = []
    f.solver = lambda diagonal, below: whole.extend([diagonal, below])  # capture the whole factorisation's factors
    assert f.factorise(K) is None and len(whole) == 2
    values = f.pattern_values(K)
    blocks: list = [None] * f.supernodes
    below: list = [None] * f.supernodes
    half_updates = [{}, {}]
    for half, updates in zip(halves, half_updates):  # apart: a missing child update would raise KeyError
        assert f.factor_supernodes(half.tolist(), values, updates, blocks, below)
    updates = {**half_updates[0], **half_updates[1]}
    assert f.factor_supernodes(top.tolist(), values, updates, blocks, below)
    assert not updates  # every update matrix was consumed by its parent
    for s in range(f.supernodes):
        assert np.array_equal(blocks[s], whole[0][s])
        assert (below[s] is None and whole[1][s] is None) or np.array_equal(below[s], whole[1][s])


@pytest.mark.slow
def test_two_process_factorisation_matches_the_serial_one(wall_K):
    """``processes=2``: a worker process factorises and solves one subtree half.  Its factors are the serial ones
    (the same fronts, the same order), so its solutions agree with the serial solve to round-off; a vector and a
    matrix of columns are solved; a solver whose factors a later factorisation replaced refuses to solve; a matrix
    that is not positive definite gives None, and the worker stays in step for the next one; ``close`` ends it."""
    K, pattern = wall_K
    serial = SupernodalCholesky(pattern, "metis")
    split = SupernodalCholesky(pattern, "metis", processes=2)
    rng = np.random.default_rng(3)
    b = rng.standard_normal(K.shape[0])
    B = rng.standard_normal((K.shape[0], 3))
    x_serial, X_serial = (solve := serial.factorise(K))(b), solve(B)
    split.start_worker(wait=True)
    solve_split = split.factorise(K)
    x, X = solve_split(b), solve_split(B)
    scale = np.linalg.norm(x_serial)
    assert np.linalg.norm(x - x_serial) <= 1e-12 * scale
    assert np.linalg.norm(X - X_serial) <= 1e-12 * np.linalg.norm(X_serial)
    assert np.linalg.norm(K @ x - b) <= 1e-10 * np.linalg.norm(b)
    assert split.solves == 2 and split.factorisations == 1
    assert split.worker_cpu_s > 0 and split.worker_factorisations == 1  # the worker's CPU time, with its factorisation
    indefinite = sp.csc_array(K - 2 * abs(K).max() * sp.eye_array(K.shape[0]))
    assert split.factorise(indefinite) is None
    with pytest.raises(RuntimeError, match="replaced by a later factorisation"):
        solve_split(b)
    again = split.factorise(K)
    assert np.linalg.norm(again(b) - x_serial) <= 1e-12 * scale
    process = split.worker.process
    split.close()
    assert process.returncode == 0  # stopped when asked, and reaped
    with pytest.raises(ValueError, match="processes must be 1 or 2"):
        SupernodalCholesky(pattern, "metis", processes=3)


@pytest.mark.slow
def test_static_lp_factor_processes_reaches_the_block_ipm(monkeypatch):
    """``static-lp``'s setting ``factor_processes`` (:class:`~blockmpec.solvers.static_lp.LPSettings`) is the block
    IPM's; with the supernodal Cholesky forced on a small wall, 2 gives the serial optimum, verified, through
    :func:`bm.run_solver`, and the result reports the worker's CPU; the default (``"auto"``) keeps one process on a
    small ``K``; 3 and 1.5 are one clear option error each, naming the setting."""
    from blockmpec.errors import OptionError
    from blockmpec.solvers.static_lp import LPSettings

    _supernodal_on_any_size(monkeypatch)
    _worker_ready_at_once(monkeypatch)
    wall = bm.cases.wall(10, 20)
    one = bm.solve(wall, "static-lp", algorithm="block-ipm")
    two = solve_with(wall, "static-lp", settings=dict(factor_processes=2), algorithm="block-ipm")
    assert one.verified and two.verified
    assert two.multiplier == pytest.approx(one.multiplier, rel=1e-8)
    assert "factor_processes" not in one.extra  # the default on a small K: one process
    assert two.extra["factor_processes"] == 2 and two.extra["factor_worker_cpu_s"] > 0
    assert two.extra["factor_worker_factorisations"] >= two.iterations > 0  # one or more per iteration, shared
    solver = bm.get_solver("static-lp")(algorithm="block-ipm", settings=LPSettings(factor_processes=2))
    solver.setup(bm.assemble(wall))
    assert solver.engine.factor_processes == 2
    for bad in (3, 1.5):
        with pytest.raises(OptionError, match="factor_processes must be"):
            solve_with(wall, "static-lp", settings=dict(factor_processes=bad), algorithm="block-ipm")


def test_static_lp_factor_processes_is_no_bool():
    """True is no choice of processes (``True == 1`` in Python): one clear error naming the setting."""
    from blockmpec.errors import OptionError

    with pytest.raises(OptionError, match="factor_processes must be"):
        solve_with(bm.cases.wall(3, 2), "static-lp", settings=dict(factor_processes=True), algorithm="block-ipm")


def test_auto_factor_processes_takes_two_from_its_threshold_with_two_cpus(monkeypatch):
    """``factor_processes="auto"`` (the default) is 2 for a supernodal ``K`` of at least ``rules.two_process_rows``
    rows when two CPUs are usable, and 1 below the threshold or on one CPU; an explicit 1 or 2 is kept."""
    from blockmpec.solvers.linalg import block_ipm

    ops = bm.assemble(bm.cases.wall(10, 20))
    lp = compile_linear(static_lp(ops))
    engine = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
    assert engine.factor_processes == "auto"
    n = engine.K_pattern.shape[0]
    for threshold, cpus, setting, expected in ((n, 2, "auto", 2), (n + 1, 2, "auto", 1), (n, 1, "auto", 1),
                                               (n + 1, 2, 2, 2), (n, 2, 1, 1)):
        monkeypatch.setattr(engine, "rules", dataclasses.replace(BLOCK_IPM_RULES, two_process_rows=threshold))
        monkeypatch.setattr(block_ipm, "usable_cpus", lambda: cpus)
        engine.settings(factor_processes=setting)
        assert engine.supernodal_processes == expected, (threshold, cpus, setting)
    with pytest.raises(ValueError, match="factor_processes must be one of auto, 1, 2"):
        engine.settings(factor_processes=3)
    # an interpreter that cannot start the worker (no sys.executable): "auto" keeps one process, 2 is an error
    monkeypatch.setattr(engine, "rules", dataclasses.replace(BLOCK_IPM_RULES, two_process_rows=n))
    monkeypatch.setattr(sys, "executable", "")
    engine.settings(factor_processes="auto")
    assert engine.supernodal_processes == 1
    with pytest.raises(ValueError, match="processes=2 needs a POSIX system and sys.executable"):
        SupernodalCholesky(engine.K_pattern, "metis", processes=2)


@pytest.mark.slow
@pytest.mark.parametrize("compiled", [False, True])
def test_factorisations_stay_serial_until_the_worker_is_ready(wall_K, monkeypatch, compiled):
    """While the worker process starts (its set-up is sent in the background), ``processes=2`` factorises here
    alone: the serial factors, bit for bit, and no factorisation counted as shared; once it is ready, it shares.
    The solves made here meanwhile have the worker's arithmetic: a vector and a matrix are solved to the numbers
    of the two-process solve bit for bit (so a run's iterates do not depend on when the worker is ready), which
    differ from the serial solve's in round-off only."""
    from blockmpec.solvers.linalg import cholesky

    if compiled:
        pytest.importorskip("numba")
    K, pattern = wall_K
    rng = np.random.default_rng(5)
    b, B = rng.standard_normal(K.shape[0]), rng.standard_normal((K.shape[0], 2))
    serial = SupernodalCholesky(pattern, "metis")
    serial.compiled_solves = compiled
    x_serial = serial.factorise(K)(b)
    split = SupernodalCholesky(pattern, "metis", processes=2)
    split.compiled_solves = compiled
    # The promise holds where the block IPM makes it: inside its solve, whose BLAS runs on one thread here as in the
    # worker (single_blas_thread).  With several BLAS threads in this process its half's dense kernels may group
    # sums otherwise than the worker's one thread (3e-14 relative apart, issue 39), so this test pins them too.
    with single_blas_thread():
        with monkeypatch.context() as m:
            m.setattr(cholesky.HalfWorker, "ready", lambda self: False)
            m.setattr(cholesky, "FIRST_WORKER_WAIT", 0.05)
            early = split.factorise(K)
            x_early, X_early = early(b), early(B)
        assert split.factorisations == 1 and split.worker_factorisations == 0 and split.worker is not None
        assert np.linalg.norm(x_early - x_serial) <= 1e-12 * np.linalg.norm(x_serial)
        split.start_worker(wait=True)
        shared = split.factorise(K)
        x, X = shared(b), shared(B)
    assert split.worker_factorisations == 1
    assert np.array_equal(x, x_early) and np.array_equal(X, X_early)
    assert not np.array_equal(x, x_serial)  # the top's sums are grouped otherwise: the check above can fail
    split.close()


@pytest.mark.slow
@pytest.mark.parametrize("compiled", [False, True])
def test_the_first_factorisation_waits_for_a_starting_worker(wall_K, monkeypatch, compiled):
    """The first factorisation waits (at most ``FIRST_WORKER_WAIT`` s, here long enough) for the worker, having warmed
    this process's half meanwhile (compiled: its plan is made), and is then shared: the serial factors' solutions to
    round-off, and the same numbers as a shared factorisation made later."""
    from blockmpec.solvers.linalg import cholesky

    if compiled:
        pytest.importorskip("numba")
    monkeypatch.setattr(cholesky, "FIRST_WORKER_WAIT", 120.0)
    K, pattern = wall_K
    b = np.random.default_rng(6).standard_normal(K.shape[0])
    x_serial = SupernodalCholesky(pattern, "metis").factorise(K)(b)
    split = SupernodalCholesky(pattern, "metis", processes=2, compiled_solves=compiled,
                               compiled_factorisation=compiled)
    x_first = split.factorise(K)(b)
    assert split.factorisations == split.worker_factorisations == 1
    assert (len(split.factor_plans) == 2) is compiled  # this process's half (warmed while waiting) and the top
    assert np.linalg.norm(x_first - x_serial) <= 1e-12 * np.linalg.norm(x_serial)
    assert np.array_equal(split.factorise(K)(b), x_first)
    split.close()


@pytest.mark.slow
def test_a_worker_stops_with_its_cholesky_before_any_factorisation(wall_K):
    """The worker process starts with the Cholesky (its imports overlap the analysis) and gets its set-up at the end
    of the analysis; a Cholesky closed before any factorisation stops it, and so does closing a worker that never got
    its set-up (it was waiting for it), which also closes the shared memory's file it never mapped."""
    _, pattern = wall_K
    split = SupernodalCholesky(pattern, "metis", processes=2)
    process = split.worker.process
    assert split.worker.chol is split
    split.close()
    assert process.poll() is not None
    from blockmpec.solvers.linalg.cholesky import HalfWorker

    waiting = HalfWorker()
    assert waiting.chol is None and not waiting.ready()
    process, (fd,) = waiting.process, waiting.unmapped_fds
    os.fstat(fd)  # open until the worker is set up or stopped
    waiting.close()
    assert process.poll() is not None
    with pytest.raises(OSError):
        os.fstat(fd)


@pytest.mark.slow
def test_a_worker_that_dies_is_one_clear_error(wall_K):
    """A worker process that ends in the middle of a solve (killed, out of memory) makes the next factorisation raise
    one RuntimeError that says so, never a hang or a wrong solution."""
    K, pattern = wall_K
    split = SupernodalCholesky(pattern, "metis", processes=2)
    split.start_worker(wait=True)
    split.worker.process.kill()
    split.worker.process.wait()
    with pytest.raises(RuntimeError, match="worker process ended unexpectedly"):
        split.factorise(K)
    split.close()


# --------------------------------------------------------------------------- compiled solves (numba)


@pytest.mark.slow
def test_compiled_solves_are_the_python_loops_bit_for_bit(wall_K, monkeypatch):
    """``compiled_solves`` runs the loop over supernodes compiled, calling the same BLAS routines: the solution of
    ``K x = b`` is the Python loop's bit for bit, in one process and split with a worker (whose own half is
    compiled too); a matrix of right-hand sides keeps the Python path."""
    pytest.importorskip("numba")
    K, pattern = wall_K
    _worker_ready_at_once(monkeypatch)
    b = np.random.default_rng(8).standard_normal(K.shape[0])
    B = np.random.default_rng(9).standard_normal((K.shape[0], 2))
    for processes in (1, 2):
        solutions = []
        for compiled in (False, True):
            chol = SupernodalCholesky(pattern, "metis", processes=processes)
            chol.compiled_solves = compiled
            solve = chol.factorise(K)
            solutions.append((solve(b), solve(B)))
            assert np.abs(K @ solutions[-1][0] - b).max() <= 1e-8 * np.abs(b).max()
            chol.close()
        assert np.array_equal(solutions[0][0], solutions[1][0]), processes
        assert np.array_equal(solutions[0][1], solutions[1][1]), processes


def test_compiled_solve_refuses_what_it_cannot_solve_in_place(wall_K):
    pytest.importorskip("numba")
    K, pattern = wall_K
    chol = SupernodalCholesky(pattern, "metis")
    chol.compiled_solves = True
    diagonal_blocks, below_blocks = [None] * chol.supernodes, [None] * chol.supernodes
    assert chol.factor_supernodes(range(chol.supernodes), chol.pattern_values(K), {}, diagonal_blocks, below_blocks)
    panels = chol.solve_panels(diagonal_blocks, below_blocks)
    with pytest.raises(ValueError, match="contiguous float64 vector"):
        panels.forward(np.zeros((chol.n, 2))[:, 0], range(chol.supernodes))
    half = [None] * chol.supernodes
    half[:3] = diagonal_blocks[:3]
    with pytest.raises(ValueError, match="a supernode without factors in this process"):
        chol.solve_panels(half, below_blocks).forward(np.zeros(chol.n), range(chol.supernodes))


# --------------------------------------------------------------------------- compiled factorisation (numba)


def _factors(chol: SupernodalCholesky, values: np.ndarray) -> tuple[list, list] | None:
    diagonal_blocks, below_blocks = [None] * chol.supernodes, [None] * chol.supernodes
    if not chol.factor_supernodes(range(chol.supernodes), values, {}, diagonal_blocks, below_blocks):
        return None
    return diagonal_blocks, below_blocks


def _same_blocks(first: list, second: list) -> bool:
    return all((a is None and b is None) or (a is not None and b is not None and np.array_equal(a, b))
               for a, b in zip(first, second, strict=True))


@pytest.mark.parametrize("relax", [0.0, 4.0])
def test_compiled_factorisation_is_the_python_loops_bit_for_bit(wall_K, relax):
    """``compiled_factorisation`` runs the multifrontal loop compiled (a postorder with a stack of update matrices),
    calling the same LAPACK/BLAS on the same fronts: every block of ``L~`` is the Python loop's bit for bit (with
    and without amalgamation), and an indefinite matrix is reported as by the Python loop."""
    pytest.importorskip("numba")
    K, pattern = wall_K
    factors = []
    for compiled in (False, True):
        chol = SupernodalCholesky(pattern, "metis", relax=relax)
        chol.compiled_factorisation = compiled
        factors.append(_factors(chol, chol.pattern_values(K)))
        indefinite = sp.csc_array(K - 2.0 * sp.diags_array(K.diagonal()))
        assert chol.factorise(indefinite) is None
    assert _same_blocks(factors[0][0], factors[1][0]) and _same_blocks(factors[0][1], factors[1][1])


@pytest.mark.slow
def test_compiled_factorisation_in_halves_and_top_is_the_whole(wall_K, monkeypatch):
    """The compiled loop on the halves and then the top (:meth:`SupernodalCholesky.subtree_halves`), the top taking
    the halves' root updates, gives the whole factorisation's blocks; with a worker process (its half compiled as
    well) the solution is the Python loop's to round-off."""
    pytest.importorskip("numba")
    K, pattern = wall_K
    chol = SupernodalCholesky(pattern, "metis")
    chol.compiled_factorisation = True
    values = chol.pattern_values(K)
    whole = _factors(chol, values)
    (half_0, half_1), top = chol.subtree_halves()
    assert top.size and half_0.size and half_1.size
    diagonal_blocks, below_blocks = [None] * chol.supernodes, [None] * chol.supernodes
    updates: dict = {}
    for part in (half_0, half_1, top):
        assert chol.factor_supernodes(part.tolist(), values, updates, diagonal_blocks, below_blocks)
    assert not updates  # the top took every root update
    assert _same_blocks(whole[0], diagonal_blocks) and _same_blocks(whole[1], below_blocks)
    _worker_ready_at_once(monkeypatch)
    b = np.random.default_rng(10).standard_normal(K.shape[0])
    solutions = []
    for compiled in (False, True):
        split = SupernodalCholesky(pattern, "metis", processes=2)
        split.compiled_factorisation = compiled
        solutions.append(split.factorise(K)(b))
        assert split.worker_factorisations == 1
        split.close()
    assert np.linalg.norm(solutions[1] - solutions[0]) <= 1e-12 * np.linalg.norm(solutions[0])


def test_compiled_factorisation_keeps_the_factors_a_solver_still_holds(wall_K):
    """The compiled loop reuses its factor array only when no earlier factorisation's blocks use it: a solver kept
    from an earlier factorisation still solves with its own matrix after later ones."""
    pytest.importorskip("numba")
    K, pattern = wall_K
    chol = SupernodalCholesky(pattern, "metis")
    chol.compiled_factorisation = True
    b = np.random.default_rng(11).standard_normal(K.shape[0])
    kept = chol.factorise(K)
    scaled = [chol.factorise(2.0 ** k * K) for k in range(1, 4)]  # more than the arrays kept for reuse
    x = kept(b)
    assert np.abs(K @ x - b).max() <= 1e-8 * np.abs(b).max()
    for k, solve in enumerate(scaled, start=1):
        assert np.abs(2.0 ** k * (K @ solve(b)) - b).max() <= 1e-8 * np.abs(b).max()
    del kept, scaled
    plan = chol.factor_plan(range(chol.supernodes))
    before = [a.ctypes.data for a in plan.factor_arrays]
    chol.factorise(K)
    assert [a.ctypes.data for a in plan.factor_arrays] == before  # a free array was reused, none added


@pytest.mark.slow
def test_block_ipm_compiled_solves_follow_the_kernels_and_keep_the_iterates(monkeypatch):
    """``compiled_solves="auto"`` and ``compiled_factorisation="auto"`` compile the supernodal Cholesky's solves and
    factorisation with the compiled kernels only; True and False choose.  The solutions and factors are the same
    bit for bit, so a whole LP takes the same iterates either way."""
    pytest.importorskip("numba")
    from blockmpec.solvers.linalg import block_ipm

    _supernodal_on_any_size(monkeypatch)  # the supernodal Cholesky on a small wall
    ops = bm.assemble(bm.cases.wall(10, 20))
    lp = compile_linear(static_lp(ops))
    for name in ("compiled_solves", "compiled_factorisation"):
        outs = []
        for setting, kernels, expected in (("auto", "compiled", True), (False, "compiled", False),
                                           ("auto", "numpy", False), (True, "numpy", True)):
            engine = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
            engine.settings(kernels=kernels, factor_processes=1, **{name: setting})
            outs.append(engine.solve())
            assert getattr(engine.factoriser, name) is expected, (name, setting, kernels)
            if name == "compiled_factorisation" and expected:
                # the solve drops each iteration's factors before the next factorisation, which reuses their array
                assert [len(plan.factor_arrays) for plan in engine.factoriser.factor_plans.values()] == [1]
        assert outs[0].status is bm.Status.OPTIMAL
        assert outs[0].iterations == outs[1].iterations and np.array_equal(outs[0].v, outs[1].v), name
        assert outs[2].iterations == outs[3].iterations and np.array_equal(outs[2].v, outs[3].v), name
        for bad in ("yes", 1, 0):
            with pytest.raises(ValueError, match=f"{name} must be one of auto, True, False"):
                engine.settings(**{name: bad})
    monkeypatch.setattr(block_ipm, "compiled_kernels_available", lambda: False)
    for name in ("compiled_solves", "compiled_factorisation"):
        with pytest.raises(ValueError, match=rf"{name}=True needs numba"):
            engine.settings(**{name: True})


def test_factor_flops_count_the_dense_work_of_the_fronts():
    """``factor_flops`` is the dense work of one factorisation: a dense matrix is one front of ``n`` columns,
    ``n^3 / 3``; a block-diagonal one of ``b`` dense blocks, ``b`` times that of a block; an arrow matrix (a dense
    last row and column) eliminates ``n - 1`` columns of one row below each, then the corner."""
    n = 12
    dense = SupernodalCholesky(sp.csc_array(np.ones((n, n))), "mmd")
    assert dense.factor_flops == pytest.approx(n ** 3 / 3)
    blocks = SupernodalCholesky(sp.block_diag([np.ones((4, 4))] * 5, format="csc"), "mmd")
    assert blocks.factor_flops == pytest.approx(5 * 4 ** 3 / 3)
    arrow = np.eye(n)
    arrow[-1, :] = arrow[:, -1] = 1.0
    # without amalgamation (relax 0): n - 2 fronts of one column with one row below (1/3 + 1 + 1 each), then the
    # last two columns as one dense front (8/3)
    chol = SupernodalCholesky(sp.csc_array(arrow), "mmd", relax=0)
    assert chol.supernodes == n - 1
    assert chol.factor_flops == pytest.approx((n - 2) * (1 / 3 + 2) + 8 / 3)


@pytest.mark.slow
def test_two_process_lp_iterates_do_not_depend_on_when_the_worker_is_ready(monkeypatch):
    """A whole block-IPM LP with ``factor_processes=2``: whether the worker is ready from the first factorisation or
    only from the fourth (the solves before then made here), the iterates, the solution and the duals are the same
    bit for bit -- so one LP's iteration count and digits do not vary with the machine's load."""
    from blockmpec.solvers.linalg import cholesky

    _supernodal_on_any_size(monkeypatch)
    ops = bm.assemble(bm.cases.wall(10, 20))
    lp = compile_linear(static_lp(ops))

    def run(late: int):
        engine = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
        engine.settings(factor_processes=2)
        ready = cholesky.HalfWorker.ready

        def ready_later(self):
            if self.chol.factorisations < late:
                return False
            while not ready(self):  # from then on, as if it had been ready at once
                time.sleep(0.01)
            return True

        with monkeypatch.context() as m:
            m.setattr(cholesky.HalfWorker, "ready", ready_later)
            m.setattr(cholesky, "FIRST_WORKER_WAIT", 0.05)
            out = engine.solve()
        return out, engine.factoriser.worker_factorisations, [row["mu"] for row in engine.trace]

    (first, shared_first, mu_first), (later, shared_later, mu_later) = run(0), run(3)
    assert first.status is bm.Status.OPTIMAL and shared_later == shared_first - 3 > 0
    assert mu_first == mu_later and first.iterations == later.iterations
    assert np.array_equal(first.v, later.v) and np.array_equal(first.row_dual, later.row_dual)

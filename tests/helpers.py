"""Helpers shared by the tests (closed forms, tolerances, assertions); fixtures live in conftest."""

import numpy as np
import scipy.sparse as sp

import blockmpec as bm
from blockmpec.verify import VERIFY_TOL


def solve_with(case, method: str, settings: dict | None = None, *, verify_tol: float = VERIFY_TOL,
               **options) -> bm.Result:
    """:func:`bm.solve` with engine settings: the method's ``Settings(**settings)`` (its experiment knobs, not options)
    on a configured instance, run by :func:`bm.run_solver`; ``options`` are the method's options as for ``bm.solve``."""
    cls = bm.get_solver(method)
    configured = cls(settings=cls.Settings(**settings) if settings else None, **options)
    return bm.run_solver(configured, case, verify_tol=verify_tol)


def two_block_associative(eta: float, mu: float) -> float:
    """Closed-form associative multiplier of the paper's two-block problem (Sect. 3)."""
    return bm.cases.closed_form("two-blocks", "associative", eta=eta, mu=mu)


def two_block_nonassociative_min(eta: float, mu: float) -> float:
    """Closed-form minimum non-associative multiplier (psi = 0): mu if mu <= 1/eta else 1/eta."""
    return bm.cases.closed_form("two-blocks", "non-associative", eta=eta, mu=mu)


#: the non-associative methods other than the certified ``milp``
HEURISTICS = [m for m in bm.list_solvers("non-associative") if m != "milp"]
#: the heuristics that return a verified solution of (3) on every small case of the tests (measured); slp, whose
#: answers need not solve (3) (``exact_solution = False``: its tilted friction surface leaves dilatancy), and methods
#: registered later may fail there, but only as :func:`assert_reported_unverified` says
SOLVES_SMALL_CASES = ("fixed-point", "mcp-newton", "nlp")
#: A heuristic's success means every relative residual of (3) is at most ``verify_tol`` = 1e-6
#: (bm.solve's default), so its multiplier is that of an exact solution of (3) only to about 1e-6
#: on lam's scale max(1, |lam|) (unit-density loads: the live load is the weight).
HEURISTIC_TOL = 1e-6
#: ``milp`` results are polished to round-off (exact LPs on a fixed pattern) and certified up to its
#: CERTIFICATE_TOL = 1e-7 (times max(1, |lam|)); the static LP's optimum is exact to HiGHS's 1e-9.
CERTIFIED_TOL = 1e-7


def margin(tol: float, lam: float) -> float:
    """``tol`` on lam's scale ``max(1, |lam|)``."""
    return tol * max(1.0, abs(lam))


def assert_success(res: bm.Result, multiplier: float | None = None, rtol: float = 1e-8) -> None:
    """A scipy-style assertion helper: success, and the multiplier if given."""
    assert res.success, f"{res.method}: status {res.status.value}, message: {res.message}, residuals {res.residuals}"
    if multiplier is not None:
        np.testing.assert_allclose(res.multiplier, multiplier, rtol=rtol)


def assert_reported_unverified(res: bm.Result) -> None:
    """What a method that may fail (not in :data:`SOLVES_SMALL_CASES`) must do when its point is not a solution of
    (3): report it, unverified, never as a success and never as a proof of anything: status ``numerical`` with the
    residual above ``verify_tol`` named in the message (or ``iteration_limit``), its ``lam`` and its residuals (the
    friction-admissibility error, the paper's Table 2 measure, among them) reported."""
    assert not res.success and not res.verified, (res.status, res.residuals)
    assert res.status in (bm.Status.NUMERICAL, bm.Status.ITERATION_LIMIT), (res.status, res.message)
    worst = max(res.residuals, key=res.residuals.get)
    assert res.residuals[worst] > res.verify_tol, res.residuals
    if res.status is bm.Status.NUMERICAL:
        assert f"verifier disagrees: {worst} residual" in res.message, res.message
    assert res.multiplier is not None and np.isfinite(res.multiplier)
    assert np.isfinite(res.residuals["friction_admissibility"])


def assert_residuals_within(res: bm.Result, tol: float, status: bm.Status | None = None) -> None:
    """The run claims success (or exactly ``status``) and every residual of (3) is at most ``tol``."""
    if status is None:
        assert res.status.is_success, f"{res.status.value}: {res.message}"
    else:
        assert res.status is status, f"{res.status.value}: {res.message}"
    assert res.residuals, "no residuals"
    worst = max(res.residuals, key=res.residuals.get)
    assert res.residuals[worst] <= tol, f"{worst} = {res.residuals[worst]:.3g}"


def block_on_block(big: float, small: float) -> bm.Structure:
    """A ``big`` square block on a fixed base carrying a ``small x 2 small`` block (rocks first at lam = 0.5)."""
    # a big x big block carrying a small x 2 small block: the small block topples first at lam = b/h = 0.5
    polys = [
        [[-2 * big, -big / 10], [3 * big, -big / 10], [3 * big, 0], [-2 * big, 0]],
        [[0, 0], [big, 0], [big, big], [0, big]],
        [[big / 2, big], [big / 2 + small, big], [big / 2 + small, big + 2 * small], [big / 2, big + 2 * small]],
    ]
    return bm.make_structure(polys, [True, False, False], friction=0.65)


def assert_same_program(a, b) -> None:
    """Two compiled LinearPrograms are bitwise equal (CSR structure included, not only values)."""
    A, B = sp.csr_array(a.A), sp.csr_array(b.A)
    A.sort_indices(), B.sort_indices()
    assert A.shape == B.shape
    for name in ("indptr", "indices", "data"):
        np.testing.assert_array_equal(getattr(A, name), getattr(B, name))
    for name in ("c", "row_lower", "row_upper", "col_lower", "col_upper"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.columns.keys() == b.columns.keys() and a.rows.keys() == b.rows.keys()
    for g in a.columns:
        np.testing.assert_array_equal(a.columns[g], b.columns[g])
    for g in a.rows:
        np.testing.assert_array_equal(a.rows[g], b.rows[g])
    assert (a.objective_sign, a.objective_offset) == (b.objective_sign, b.objective_offset)


def assert_certified(res: bm.Result, sense: str = "min") -> None:
    """A ``milp`` result is a certificate: optimal, verified, no active big-M, its gap closed, its bound on the
    right side of its multiplier, and the polished point's residuals of (3) at most ``CERTIFIED_TOL``."""
    assert res.status is bm.Status.OPTIMAL, f"{res.status.value}: {res.message}"
    assert res.verified
    assert res.extra["sense"] == sense
    assert res.extra["bigm_active"] == []
    # closed gap: the polished (exact) multiplier meets the branch-and-bound dual bound
    assert res.extra["gap_abs"] <= 1e-7 * max(1.0, abs(res.multiplier))
    if sense == "min":  # the dual bound is a lower bound on the minimum ...
        assert res.extra["bound"] <= res.multiplier + 1e-7
        assert "minimum" in res.message
    else:  # ... and an upper bound on the maximum
        assert res.extra["bound"] >= res.multiplier - 1e-7
        assert "maximum" in res.message and "minimum" not in res.message
    assert max(res.residuals.values()) <= CERTIFIED_TOL, res.residuals


#: small structures and their certified minima; the opening wall and the two-block case have a minimum
#: below the associative multiplier (a bound at the associative value there would be wrong)
LIFTING_CASES = {
    "wall-2x2": lambda: bm.cases.wall(2, 2),
    "two-blocks": lambda: bm.cases.two_blocks(eta=3, mu=0.65),
    "wall-3x2-opening": lambda: bm.cases.wall(3, 2, openings=[[0.5, 0.5, 1.5, 1.0]]),
    "wall-4x2-stack-mu0.4": lambda: bm.cases.wall(4, 2, bond="stack", mu=0.4),
    "arch-6": lambda: bm.cases.round_arch(n_voussoirs=6, thickness=0.15),
}


def wall_block_ipm_off_path(spread: float, seed: int, courses: int = 10, blocks_per_course: int = 20):
    """The block IPM on the static LP of a running-bond wall (load units) and an iterate off the central path:
    Mehrotra's starting point with ``s`` and ``y`` each multiplied by ``exp(N(0, spread))``, so the products
    ``s y`` spread over many decades, as near the optimum."""
    from blockmpec.formulations import compile_linear, static_lp
    from blockmpec.solvers.engines.block_lp import BlockLP
    from blockmpec.solvers.engines.lp_engine import cold_lp_engine
    from blockmpec.solvers.engines.scaling import LoadUnits

    ops = bm.assemble(bm.cases.wall(courses, blocks_per_course))
    lp = compile_linear(static_lp(ops))
    ipm = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
    assert isinstance(ipm, BlockLP)
    it = ipm.initial_point()
    rng = np.random.default_rng(seed)
    it.s *= np.exp(rng.normal(0.0, spread, it.s.size))
    it.y *= np.exp(rng.normal(0.0, spread, it.y.size))
    return ipm, it

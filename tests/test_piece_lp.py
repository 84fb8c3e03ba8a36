"""Split piece LPs (solvers/engines/piece_lp.py): the static (lam, x) and kinematic (u, z) halves of a piece of
(4), shared by nlp's piece descent and milp's polish; their certificate of local minimality."""

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.result import Status
from blockmpec.solvers.engines.scaling import LoadUnits
from helpers import assert_residuals_within, two_block_associative, two_block_nonassociative_min

TOL = 1e-6


def assert_verified(res):
    assert_residuals_within(res, TOL)


def _setup(case, engine="dual-simplex"):
    from blockmpec.formulations import compile_mcp
    from blockmpec.solvers.engines.piece_lp import SplitPieces

    ops = bm.assemble(case)
    form = compile_mcp(ops)
    scaling = LoadUnits.of(ops).mcp(form)
    return ops, form, scaling, SplitPieces(form, scaling, static_engine=engine)


def _start_rounding(pieces, w):
    """The pairs whose slack is relatively the smaller side at ``w`` (the whole route's first piece)."""
    from blockmpec.solvers.engines.piece_lp import relative_to_largest

    z, s = pieces.sides(w)
    return relative_to_largest(s) <= relative_to_largest(z)


@pytest.mark.parametrize("case", [bm.cases.wall(3, 2), bm.cases.wall(10, 5)], ids=["wall-3x2", "wall-10x5"])
def test_split_halves_are_the_whole_piece_lp(case):
    """On one piece, min lam of the whole LP (PieceLP, HiGHS) equals the static half's, and the whole LP's
    (u, z) is feasible for the kinematic half: no row couples them."""
    from blockmpec.solvers.engines.piece_lp import PieceLP

    ops, form, scaling, pieces = _setup(case)
    fp = bm.solve(case, "fixed-point")
    piece = _start_rounding(pieces, form.pack(fp.solution))
    whole = PieceLP(form, scaling)
    whole.set_piece(piece)
    out = whole.solve()
    static = pieces.static_lp(piece)
    mech = pieces.mechanism(piece)
    assert out.status is static.status is mech.status is Status.OPTIMAL
    assert static.objective == pytest.approx(out.objective, abs=1e-9)
    z = out.v[form.pair_column]
    assert np.all(z[~piece] == 0.0)
    # the kinematic rows hold at the whole LP's point
    rows = np.r_[np.arange(form.compatibility.start, form.compatibility.stop), form.normalisation.start]
    np.testing.assert_allclose(form.A[rows] @ out.v, form.rhs[rows], atol=1e-9)


def test_certificate_fails_where_the_relaxed_lp_goes_lower():
    """10x5 wall: the point of the start's piece (static LP with an equality on every pair whose slack is the
    smaller side, mechanism of least 1^T z) has equalities on pairs whose multiplier is 0; six of them have a
    positive dual, so the certificate fails, and the whole relaxed LP (PieceLP, those pairs free) indeed goes
    lower.  The descent's point from the same start is certified, and the whole relaxed LP at it does not go lower."""
    from blockmpec.solvers.engines.piece_lp import PieceLP, piece_descent

    case = bm.cases.wall(10, 5)
    ops, form, scaling, pieces = _setup(case)
    fp = bm.solve(case, "fixed-point")
    w0 = form.pack(fp.solution)
    piece = _start_rounding(pieces, w0)
    static, mech = pieces.static_lp(piece), pieces.mechanism(piece)
    w = pieces.point(static, mech)
    cert = pieces.certificate(w, static)
    assert not cert.holds and cert.wrong_signs > 0
    assert cert.stationarity <= 1e-9 and cert.complementarity <= 1e-9  # an exact solution of (3) ...
    whole = PieceLP(form, scaling)

    def relaxed_lam(point):
        z, s = whole.sides(point)
        both_zero = (z <= 1e-9) & (s <= 1e-9)
        whole.set_piece(s <= 1e-9, free=both_zero)
        out = whole.solve(cold=True)
        assert out.status is Status.OPTIMAL
        return out.objective

    assert relaxed_lam(w) < static.objective - 1e-6  # ... but not a local minimum of (4)
    out = piece_descent(form, scaling, w0)
    assert out.status is Status.LOCALLY_OPTIMAL and out.certificate.holds
    assert relaxed_lam(out.w) >= out.multiplier - 1e-9
    assert out.multiplier < static.objective - 1e-4


def test_certificate_fails_when_lam_is_not_the_lps_optimum():
    """The fixed point's own solution of (3) with the duals of the static LP of its support: lam is above that
    LP's optimum (0.51447 against 0.50582 on the 10x5 wall, measured), so those duals certify nothing."""
    case = bm.cases.wall(10, 5)
    ops, form, scaling, pieces = _setup(case)
    fp = bm.solve(case, "fixed-point")
    w = form.pack(fp.solution)
    z, _ = pieces.sides(w)
    static = pieces.static_lp(z > 1e-9)
    assert static.status is Status.OPTIMAL and static.objective < fp.multiplier - 1e-3
    cert = pieces.certificate(w, static, tol=1e-6)
    assert not cert.holds and cert.lam_gap > 1e-3


@pytest.mark.parametrize(("case", "certified"), [
    (bm.cases.wall(4, 2, bond="stack"), 0.5),  # milp's certified minimum (README)
    (bm.cases.two_blocks(eta=3, mu=0.65), 1 / 3),  # closed form
], ids=["wall-4x2-stack", "two-blocks"])
def test_milp_certified_point_is_a_certified_piece(case, certified):
    """milp's certified global minimum, its pattern's static half re-solved in nlp's units: the same lam, and the
    split certificate holds there (a global minimum is a local one)."""
    res = bm.solve(case, "milp")
    assert res.status is Status.OPTIMAL
    assert res.multiplier == pytest.approx(certified, abs=TOL)
    ops, form, scaling, pieces = _setup(case)
    w = form.pack(res.solution)
    z, _ = pieces.sides(w)
    support = z > 1e-9
    static = pieces.static_lp(support)
    assert static.objective == pytest.approx(res.multiplier, abs=1e-9)
    w[form.pair_column] = np.where(support, w[form.pair_column], 0.0)
    w[pieces.s_cols] = static.v
    assert pieces.certificate(w, static).holds


@pytest.mark.parametrize(("eta", "mu"), [(3, 0.65), (5, 0.3), (2, 0.9)])
def test_piece_route_two_blocks_between_closed_forms(eta, mu):
    """nlp route='pieces': verified, certified, between the closed-form minimum of (4) and the associative lam."""
    res = bm.solve(bm.cases.two_blocks(eta=eta, mu=mu), "nlp", route="pieces")
    assert_verified(res)
    assert res.status is Status.LOCALLY_OPTIMAL and res.extra["piece_certified"] and res.extra["route"] == "pieces"
    assert two_block_nonassociative_min(eta, mu) - TOL <= res.multiplier <= two_block_associative(eta, mu) + TOL


def test_block_ipm_static_half_matches_highs_with_closed_interfaces():
    """The block IPM's static half (closed interfaces left out, their duals by least squares) gives HiGHS's lam on
    the same support, and its duals certify the same point."""
    from blockmpec.solvers.engines.piece_lp import closed_interfaces

    case = bm.cases.wall(10, 5)
    _, form, scaling, simplex = _setup(case, "dual-simplex")
    _, _, _, ipm = _setup(case, "block-ipm")
    fp = bm.solve(case, "fixed-point")
    piece = _start_rounding(simplex, form.pack(fp.solution))
    mech = simplex.mechanism(piece)
    support = simplex.support(mech)
    assert closed_interfaces(support, form.pair_interface, form.pair_kind, form.n_interfaces).any()
    a, b = simplex.static_lp(support), ipm.static_lp(support)
    assert a.status is b.status is Status.OPTIMAL
    assert b.objective == pytest.approx(a.objective, abs=1e-8)
    assert ipm.certificate(ipm.point(b, mech), b).holds
    assert simplex.certificate(simplex.point(a, mech), a).holds


def test_closed_interfaces_are_those_whose_cone_is_zero():
    """Every subset of one interface's four pair rows as equalities: closed exactly when the other rows leave
    only x_k = 0 (checked by an LP: max |t| + |n| + |m| in the unit box over that face of the cone)."""
    import itertools

    from scipy.optimize import linprog

    from blockmpec.solvers.engines.piece_lp import closed_interfaces

    _, form, _, _ = _setup(bm.cases.wall(2, 2))
    k = 1
    own = np.flatnonzero(form.pair_interface == k)
    G = form.G[own][:, form.x.start + 3 * k + np.arange(3)].toarray()
    for r in range(5):
        for subset in itertools.combinations(range(4), r):
            eq = np.zeros(4, bool)
            eq[list(subset)] = True
            slack_zero = np.zeros(form.n_pairs, bool)
            slack_zero[own[eq]] = True
            closed = closed_interfaces(slack_zero, form.pair_interface, form.pair_kind, form.n_interfaces)[k]
            largest = 0.0
            for sign in itertools.product((-1.0, 1.0), repeat=3):  # max sign . x over the face in the box
                out = linprog(-np.array(sign), A_ub=G[~eq] if (~eq).any() else None, b_ub=np.zeros((~eq).sum()) if (~eq).any() else None,
                              A_eq=G[eq] if eq.any() else None, b_eq=np.zeros(eq.sum()) if eq.any() else None,
                              bounds=[(-1, 1)] * 3)
                largest = max(largest, -out.fun)
            assert closed == (largest <= 1e-12), subset


@pytest.mark.slow
def test_route_auto_takes_pieces_from_100_blocks():
    """route='auto' (the default): Ipopt below NLP_PIECE_ROUTE_BLOCKS free blocks, the split piece LPs from there on."""
    from blockmpec.solvers.plan import NLP_PIECE_ROUTE_BLOCKS as PIECE_ROUTE_BLOCKS

    small = bm.solve(bm.cases.wall(4, 2, bond="stack"), "nlp")
    assert small.extra["route"] == "ipopt" and small.iterations > 0
    case = bm.cases.wall(10, 10)
    assert case.n_free >= PIECE_ROUTE_BLOCKS
    big = bm.solve(case, "nlp")
    assert_verified(big)
    assert big.extra["route"] == "pieces" and big.iterations == 0 and big.extra["piece_certified"]
    fp = bm.solve(case, "fixed-point")
    assert big.multiplier <= fp.multiplier + 1e-9

"""The ``nlp`` method: MPEC (4) by a Scholtes-relaxed NLP solved with Ipopt.

Checks: the closed-form two-block results of Nodargi, Intrigila & Bisegna (Sect. 3:
non-associative minimum ``mu`` if ``mu <= 1/eta`` else ``1/eta``; every solution of
(3) lies below the associative multiplier), the round arch of their Table 1
(0.16034; full precision from the independent LP, references.py), the associative control (``tan psi = tan phi``: the MPEC is the KKT
system of the LP, so the answer is the LP multiplier), exact derivatives of the
Ipopt callbacks, and failures reported as statuses.
"""

import numpy as np
import pytest
from references import ROUND_ARCH_ASSOCIATIVE, ROUND_ARCH_PUBLISHED, STACK_WALL_4X2_MINIMUM

import blockmpec as bm
from blockmpec.result import Status
from blockmpec.solvers.engines.scaling import LoadUnits
from helpers import (
    assert_residuals_within,
    block_on_block,
    solve_with,
    two_block_associative,
    two_block_nonassociative_min,
)

#: the verifier's tolerance (solve's default verify_tol): every residual of (3) at most this
TOL = 1e-6
#: nlp's polished answers against closed forms, certified minima and the LP: 3.3e-16 at most measured on the two
#: blocks, 1.1e-12 on the round arch, 7.4e-15 for the associative control, 1.2e-15 on the stack wall
EXACT = 1e-9


def assert_verified(res):
    assert_residuals_within(res, TOL)


@pytest.mark.parametrize(("eta", "mu"), [(3, 0.65), (2, 1.0), (5, 0.3), (1, 0.65), (4, 0.65), (2, 0.3)])
def test_two_blocks_between_bounds(eta, mu):
    res = bm.solve(bm.cases.two_blocks(eta=eta, mu=mu), "nlp")
    assert_verified(res)
    assert two_block_nonassociative_min(eta, mu) - EXACT <= res.multiplier <= two_block_associative(eta, mu) + EXACT


def test_two_blocks_paper_point_reaches_minimum():
    """eta = 3, mu = 0.65: associative 1/2.3825 (printed 0.41973), non-associative minimum 1/3 (paper, Sect. 3)."""
    res = bm.solve(bm.cases.two_blocks(eta=3, mu=0.65), "nlp")
    assert_verified(res)
    assert res.multiplier == pytest.approx(1 / 3, abs=EXACT)  # 1.1e-16 measured
    assert res.multiplier < two_block_associative(3, 0.65) - 0.08  # a 25 % reduction, not the LP answer


def test_round_arch_table_1():
    res = bm.solve(bm.cases.round_arch(), "nlp")
    assert_verified(res)
    assert res.multiplier == pytest.approx(ROUND_ARCH_ASSOCIATIVE, rel=EXACT)  # 1.1e-12 measured
    assert round(res.multiplier, 5) == ROUND_ARCH_PUBLISHED


@pytest.mark.parametrize("case", [bm.cases.two_blocks(eta=3, mu=0.65, dilatancy=0.65),
                                  bm.cases.wall(3, 2, mu=0.65, dilatancy=0.65)], ids=["two-blocks", "wall-3x2"])
def test_associative_control_gives_the_lp_multiplier(case):
    lp = bm.solve(case, "static-lp")
    assert lp.status is Status.OPTIMAL
    res = bm.solve(case, "nlp")
    assert_verified(res)
    assert res.multiplier == pytest.approx(lp.multiplier, abs=EXACT)  # 7.4e-15 measured


def test_trace_records_every_stage():
    res = solve_with(bm.cases.two_blocks(eta=3, mu=0.65), "nlp", settings=dict(polish=False), eps_initial=1e-3,
                     eps_final=1e-7)
    stages = [t for t in res.trace if t["stage"] != "polish"]
    np.testing.assert_allclose([t["eps"] for t in stages], [1e-3, 1e-4, 1e-5, 1e-6, 1e-7])
    for t in stages:
        assert {"eps", "multiplier", "ipopt_status", "ipopt_iterations", "time_s"} <= set(t)
    assert res.iterations == sum(t["ipopt_iterations"] for t in stages)


def test_iteration_limit_is_a_status():
    res = solve_with(bm.cases.two_blocks(eta=3, mu=0.65), "nlp", settings=dict(max_iter=1))
    assert res.status is Status.ITERATION_LIMIT
    assert not res.success


def test_time_limit_is_a_status():
    res = bm.solve(bm.cases.wall(5, 4), "nlp", time_limit=1e-6)
    assert res.status is Status.TIME_LIMIT
    assert not res.success


def test_time_limit_inside_ipopt_is_a_status_and_kept(monkeypatch):
    """A limit that ends inside an Ipopt stage: the status is the time limit and the trace's last Ipopt solve says
    why (our callback stopped it) after the iterations it made.  The deadline is made to pass at the fifth Ipopt
    iteration of the first stage, whatever the machine's speed (the callback's own test is below)."""
    import math

    from blockmpec.solvers.nlp import RelaxedMPEC

    intermediate = RelaxedMPEC.intermediate

    def deadline_passes_at_iteration_5(self, alg_mod, iter_count, *args):
        if iter_count >= 5:
            self.deadline = -math.inf
        return intermediate(self, alg_mod, iter_count, *args)

    monkeypatch.setattr(RelaxedMPEC, "intermediate", deadline_passes_at_iteration_5)
    res = bm.solve(bm.cases.wall(5, 4), "nlp", route="ipopt")
    assert res.status is Status.TIME_LIMIT
    assert not res.success
    last = [t for t in res.trace if t["stage"] != "polish"][-1]
    assert last["stage"] == 1 and last["ipopt_status"] == "time_limit_callback"
    assert last["ipopt_iterations"] == 5


def test_iteration_callback_stops_ipopt_at_the_deadline():
    """The callback returns False (Ipopt's user stop) once the deadline minus the longest iteration has
    passed, and records that the deadline, not the user, stopped it."""
    import time

    from blockmpec.formulations import compile_mcp
    from blockmpec.solvers.nlp import RelaxedMPEC

    ops = bm.assemble(bm.cases.two_blocks(eta=3, mu=0.65))
    form = compile_mcp(ops)
    nlp = RelaxedMPEC(form, 1.0, LoadUnits.of(ops).mcp(form))
    args = (0.0,) * 9
    nlp.start_clock(float("inf"))
    assert nlp.intermediate(0, 0, *args) and nlp.intermediate(0, 1, *args)
    assert not nlp.deadline_hit and nlp.iterations == 1
    nlp.start_clock(time.perf_counter() + 0.05)
    time.sleep(0.03)  # the first iteration took 0.03 s; 0.02 s are left: the next one would overrun
    assert not nlp.intermediate(0, 0, *args)
    assert nlp.deadline_hit
    assert nlp.longest_iteration_s >= 0.03


@pytest.mark.parametrize("bad", [dict(eps_factor=1.5), dict(eps_final=1.0, eps_initial=1e-3), dict(start="hot")])
def test_bad_options(bad):
    with pytest.raises(bm.OptionError, match=next(iter(bad)) if "eps_initial" not in bad else "eps_final"):
        bm.solve(bm.cases.single_block(), "nlp", **bad)


@pytest.mark.parametrize("bad", [dict(max_iter=2.5), dict(ipopt_options={"tol": None}), dict(penalty=0.0),
                                 dict(penalty_factor=1.0), dict(penalty_stages=0), dict(piece_lp="yes"),
                                 dict(piece_lps="half")])
def test_bad_settings(bad):
    """A bad engine setting is one line naming it."""
    from blockmpec.solvers.nlp import NLPSettings

    with pytest.raises(ValueError, match=next(iter(bad))) as err:
        NLPSettings(**bad)
    assert "\n" not in str(err.value)


def test_callbacks_have_exact_derivatives():
    """Jacobian and Lagrangian Hessian of the relaxed NLP against finite differences."""
    from blockmpec.formulations import compile_mcp
    from blockmpec.solvers.nlp import RelaxedMPEC

    ops = bm.assemble(bm.cases.two_blocks(eta=3, mu=0.65, dilatancy=0.2))
    form = compile_mcp(ops)
    nlp = RelaxedMPEC(form, 2.5, LoadUnits.of(ops).mcp(form))
    rng = np.random.default_rng(0)
    v = rng.normal(size=nlp.n)
    rows, cols = nlp.jacobianstructure()
    J = np.zeros((nlp.m, nlp.n))
    np.add.at(J, (rows, cols), nlp.jacobian(v))
    h = 1e-6
    J_fd = np.column_stack([(nlp.constraints(v + h * e) - nlp.constraints(v - h * e)) / (2 * h)
                            for e in np.eye(nlp.n)])
    np.testing.assert_allclose(J, J_fd, atol=1e-7)
    y = rng.normal(size=nlp.m)
    hr, hc = nlp.hessianstructure()
    assert np.all(hr >= hc)  # lower triangle
    H = np.zeros((nlp.n, nlp.n))
    np.add.at(H, (hr, hc), nlp.hessian(v, y, 1.0))
    H = H + np.tril(H, -1).T

    def grad_lagrangian(w):
        Jw = np.zeros((nlp.m, nlp.n))
        np.add.at(Jw, (rows, cols), nlp.jacobian(w))
        return nlp.gradient(w) + Jw.T @ y

    H_fd = np.column_stack([(grad_lagrangian(v + h * e) - grad_lagrangian(v - h * e)) / (2 * h)
                            for e in np.eye(nlp.n)])
    np.testing.assert_allclose(H, H_fd, atol=1e-6)


def test_rows_in_units_are_the_rows_of_4_scaled_and_products_unchanged():
    """A 1e-3 block on a unit block (loads 1e-6 apart): the NLP in units (solvers/nlp.py, LoadUnits.mcp) has
    rows ``R (A w - rhs)`` and ``(G w + s) / S`` at ``v^ = v / D``, the same products ``z_i s_i / P``,
    and every block's equilibrium rows and load within O(1) (the unscaled rows are 1e-6 apart)."""
    from blockmpec.formulations import compile_mcp
    from blockmpec.solvers.nlp import RelaxedMPEC

    ops = bm.assemble(block_on_block(1.0, 1e-3))
    form = compile_mcp(ops)
    scaling = LoadUnits.of(ops).mcp(form)
    column_scale, row_scale, slack_scale = scaling
    nlp = RelaxedMPEC(form, 2.5, scaling)
    rng = np.random.default_rng(1)
    w, s = rng.normal(size=form.n_columns), rng.random(form.n_pairs)
    g = nlp.constraints(nlp.to_units(np.concatenate([w, s]))) - np.concatenate([nlp.rhs, np.zeros(form.n_pairs)])
    m_eq = form.A.shape[0]
    np.testing.assert_allclose(g[:m_eq], row_scale * (form.A @ w - form.rhs), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(g[m_eq:nlp.m_lin], (form.G @ w + s) / slack_scale, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(g[nlp.m_lin:], w[form.pair_column] * s / 2.5, rtol=1e-12)
    raw = np.abs(form.f_d).reshape(-1, 3).max(axis=1)
    assert raw.max() / raw.min() > 1e5  # the two blocks' loads, unscaled
    scaled = (np.abs(row_scale[form.equilibrium] * form.f_d)).reshape(-1, 3).max(axis=1)
    assert scaled.max() / scaled.min() < 10


# ---- the penalty NLP and the fixed-point start (options complementarity="penalty", start="fixed-point")


@pytest.mark.parametrize("start", ["associative", "fixed-point"])
@pytest.mark.parametrize(("eta", "mu"), [(3, 0.65), (2, 1.0), (5, 0.3)])
def test_penalty_two_blocks_between_bounds(start, eta, mu):
    res = bm.solve(bm.cases.two_blocks(eta=eta, mu=mu), "nlp", complementarity="penalty", start=start)
    assert_verified(res)
    assert two_block_nonassociative_min(eta, mu) - EXACT <= res.multiplier <= two_block_associative(eta, mu) + EXACT


@pytest.mark.parametrize("options", [dict(complementarity="penalty"),
                                     dict(complementarity="penalty", start="fixed-point"),
                                     dict(start="fixed-point")], ids=["penalty", "penalty-fp", "relaxed-fp"])
@pytest.mark.parametrize("case", [bm.cases.wall(4, 2, bond="stack"), bm.cases.wall(3, 2),
                                  bm.cases.round_arch(n_voussoirs=8)], ids=["wall-4x2-stack", "wall-3x2", "arch-8"])
def test_variants_verified_and_below_the_associative_multiplier(options, case):
    res = bm.solve(case, "nlp", **options)
    assert_verified(res)
    lam_associative = bm.solve(case, "static-lp").multiplier
    if options.get("start", "associative") == "associative":
        assert res.extra["associative_multiplier"] == pytest.approx(lam_associative, abs=EXACT)
    assert res.multiplier <= lam_associative + EXACT
    assert res.extra["start"] == options.get("start", "associative")


def test_penalty_stack_wall_reaches_its_certified_minimum():
    """The 4x2 stack wall: certified minimum 0.5 (SCIP on the independent statement, references.py), associative
    0.55402."""
    res = bm.solve(bm.cases.wall(4, 2, bond="stack"), "nlp", complementarity="penalty", start="fixed-point")
    assert_verified(res)
    assert res.multiplier == pytest.approx(STACK_WALL_4X2_MINIMUM, abs=EXACT)  # 1.2e-15 measured


def test_penalty_trace_has_one_stage_per_rho_until_complementarity():
    res = solve_with(bm.cases.two_blocks(eta=3, mu=0.65), "nlp", complementarity="penalty",
                     settings=dict(penalty=10.0, penalty_factor=100.0, polish=False))
    stages = [t for t in res.trace if t["stage"] != "polish"]
    np.testing.assert_allclose([t["rho"] for t in stages], [10.0 * 100.0**k for k in range(len(stages))])
    assert stages[-1]["max_work"] <= 1e-9 or len(stages) == 4  # stops once every z_i s_i <= eps_final P


@pytest.mark.parametrize("bad", [dict(complementarity="smooth"), dict(start="dead-load")])
def test_bad_penalty_options(bad):
    with pytest.raises(bm.OptionError, match=next(iter(bad))):
        bm.solve(bm.cases.single_block(), "nlp", **bad)


def test_penalty_callbacks_have_exact_derivatives():
    """Gradient and Lagrangian Hessian of the penalty NLP against finite differences."""
    from blockmpec.formulations import compile_mcp
    from blockmpec.solvers.nlp import PenaltyMPEC

    ops = bm.assemble(bm.cases.two_blocks(eta=3, mu=0.65, dilatancy=0.2))
    form = compile_mcp(ops)
    nlp = PenaltyMPEC(form, 2.5, LoadUnits.of(ops).mcp(form))
    nlp.rho = 7.0
    rng = np.random.default_rng(2)
    v = rng.normal(size=nlp.n)
    h = 1e-6
    g_fd = np.array([(nlp.objective(v + h * e) - nlp.objective(v - h * e)) / (2 * h) for e in np.eye(nlp.n)])
    np.testing.assert_allclose(nlp.gradient(v), g_fd, atol=1e-7)
    rows, cols = nlp.jacobianstructure()
    assert nlp.m == nlp.A.shape[0] and len(nlp.jacobian(v)) == len(rows) == nlp.A.nnz
    hr, hc = nlp.hessianstructure()
    H = np.zeros((nlp.n, nlp.n))
    np.add.at(H, (hr, hc), nlp.hessian(v, np.zeros(nlp.m), 0.5))
    H = H + np.tril(H, -1).T
    H_fd = np.column_stack([(nlp.gradient(v + h * e) - nlp.gradient(v - h * e)) / (2 * h) for e in np.eye(nlp.n)])
    np.testing.assert_allclose(H, 0.5 * H_fd, atol=1e-6)


# ---- the piece-LP finish (route "pieces", setting piece_lp; solvers/engines/piece_lp.py)


def _form_and_fixed_point(case):
    from blockmpec.formulations import compile_mcp

    ops = bm.assemble(case)
    form = compile_mcp(ops)
    fp = bm.solve(case, "fixed-point")
    assert fp.success
    return ops, form, LoadUnits.of(ops).mcp(form), fp


def test_piece_descent_is_exact_below_its_start_and_its_certificate_holds():
    """From the fixed point of the 10x5 wall (lam 0.51447, measured): an exact solution of (3) (residuals <= 1e-12),
    lam not above the start's, certified; the certificate re-checked by solving the relaxed LP (biactive pairs
    free on both sides) explicitly: it does not go below lam."""
    from blockmpec.solvers.engines.piece_lp import PieceLP, piece_descent
    from blockmpec.verify import residuals

    case = bm.cases.wall(10, 5)
    ops, form, scaling, fp = _form_and_fixed_point(case)
    out = piece_descent(form, scaling, form.pack(fp.solution))
    assert out.status is Status.LOCALLY_OPTIMAL and out.certified
    assert max(residuals(ops, form.unpack(out.w), associative=False).values()) <= 1e-12
    assert out.multiplier <= fp.multiplier + 1e-12
    assert out.multiplier < fp.multiplier - 1e-3  # the fixed point is not a local minimum here
    plp = PieceLP(form, scaling)
    z, s = plp.sides(out.w)
    both_zero = (z <= 1e-9) & (s <= 1e-9)
    assert both_zero.any()
    plp.set_piece(s <= 1e-9, free=both_zero)
    relaxed = plp.solve(cold=True)
    assert relaxed.status is Status.OPTIMAL
    assert relaxed.objective >= out.multiplier - 1e-9


@pytest.mark.parametrize(("interior", "engine"), [(False, None), (True, None), (None, "dual-simplex"),
                                                  (None, "block-ipm")],
                         ids=["whole-simplex", "whole-interior", "split-simplex", "split-block-ipm"])
@pytest.mark.parametrize(("eta", "mu"), [(3, 0.65), (5, 0.3)])
def test_piece_descent_two_blocks_between_bounds(interior, engine, eta, mu):
    """Whole and split piece LPs, each LP engine: a certified local minimum of (4) between the closed-form minimum
    and the associative lam."""
    from blockmpec.solvers.engines.piece_lp import piece_descent, whole_piece_descent
    from blockmpec.solvers.nlp import without_free_sliding
    from blockmpec.verify import residuals

    case = bm.cases.two_blocks(eta=eta, mu=mu)
    ops, form, scaling, fp = _form_and_fixed_point(case)
    if interior is None:
        out = piece_descent(form, scaling, form.pack(fp.solution), static_engine=engine)
    else:
        out = whole_piece_descent(form, scaling, form.pack(fp.solution), interior=interior)
    assert out.certified
    solution = without_free_sliding(form, form.unpack(out.w))  # as nlp does (interior: z_f+- both large)
    assert max(residuals(ops, solution, associative=False).values()) <= 1e-7
    assert two_block_nonassociative_min(eta, mu) - TOL <= out.multiplier <= two_block_associative(eta, mu) + TOL


@pytest.mark.parametrize(("options", "settings", "wall"),
                         [(dict(route="pieces"), None, (10, 5)),
                          pytest.param(dict(route="ipopt"), dict(piece_lp=True), (5, 4), marks=pytest.mark.slow)],
                         ids=["fixed-point-pieces", "ipopt-then-pieces"])
def test_piece_lp_route_verified_certified_and_below_the_start(options, settings, wall):
    """Verified, certified (trace record of the pieces), at or below the start's lam: the fixed point's (route
    "pieces"), or the Ipopt stages' without the pieces."""
    structure = bm.cases.wall(*wall)
    if options["route"] == "pieces":
        at_most = bm.solve(structure, "fixed-point").multiplier
    else:
        at_most = solve_with(structure, "nlp", settings=dict(settings, piece_lp=False), **options).multiplier
    res = solve_with(structure, "nlp", settings=settings, **options)
    assert_verified(res)
    assert res.status is Status.LOCALLY_OPTIMAL and res.extra["piece_certified"]
    assert res.trace[-1]["stage"] == "piece-lp" and res.trace[-1]["certified"]
    assert res.multiplier <= at_most + 1e-12
    if options["route"] == "pieces":
        assert res.iterations == 0  # no Ipopt iteration
        assert res.multiplier < at_most - 1e-3  # the fixed point is not a local minimum of (4) here


def test_piece_lp_stack_wall_reaches_its_certified_minimum():
    """The 4x2 stack wall: certified minimum 0.5 (SCIP, references.py) from the fixed point by piece LPs alone."""
    res = bm.solve(bm.cases.wall(4, 2, bond="stack"), "nlp", route="pieces")
    assert_verified(res)
    assert res.multiplier == pytest.approx(STACK_WALL_4X2_MINIMUM, abs=EXACT)  # 0 measured


def test_bad_route_is_one_line():
    with pytest.raises(bm.OptionError, match="route") as err:
        bm.solve(bm.cases.single_block(), "nlp", route="lps")
    assert "\n" not in str(err.value)
